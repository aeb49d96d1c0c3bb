"""The README's trade table, printed as Markdown from a ``trade.csv`` written by benchmarks/trade.py.

Each cell is a scene's 4×4-block relative RMSE (the bias of the image mean — for the Monte Carlo
rows the mean over the bias seeds ± its standard error — ; SSIM); the last two columns are the
ranges over the scenes of the camera-move and first-frame times in VTK frames. The lowest
error among the models that are neither Monte Carlo nor built on it is in bold.

Usage: ``python benchmarks/readme_trade_table.py benchmarks/results/trade.csv``.
"""

from __future__ import annotations

import csv
import sys

SCENES = ("supernova", "cloud", "ct_phantom")
ROWS = (
    ("single scattering, preview", ("single_scattering", "preview")),
    ("ambient scattering, preview", ("ambient_scattering", "preview")),
    ("ambient scattering, balanced (BL, r = 8 vx)", ("ambient_scattering", "beer_lambert r=8")),
    ("ambient scattering, tube, r = 8 vx", ("ambient_scattering", "tube r=8")),
    ("diffusion", ("diffusion", "plain")),
    ("diffusion, flux-limited", ("diffusion", "flux-limited")),
    ("diffusion, {sweeps} + flux-limited", ("diffusion", "sweeps + FL")),  # the run's sweep count
    ("progressive, 0 spp (its first frame)", ("progressive", "0 spp")),
    ("progressive, 64 spp", ("progressive", "64 spp")),
    ("path traced, 4 spp", ("path_traced", "4 spp")),
    ("path traced, 64 spp", ("path_traced", "64 spp")),
    ("path traced, 256 spp", ("path_traced", "256 spp")),
    ("path traced + OIDN, 1 spp", ("path_traced+denoise", "1 spp")),
    ("path traced + OIDN, 4 spp", ("path_traced+denoise", "4 spp")),
    ("path traced + OIDN, 64 spp", ("path_traced+denoise", "64 spp")),
)


def load(path):
    """{scene: {(model, preset): {block, bias, ssim, move, first[, bias16][, sweeps]}}} from trade.csv
    (the sweeps row under the preset "sweeps + FL", its count as the run labelled it in ``sweeps``)."""
    data = {s: {} for s in SCENES}
    with open(path, newline="") as fh:
        for row in csv.DictReader(fh):
            r = dict(first=float(row["first"]), move=float(row["move"]), block=float(row["block_rmse"]),
                     bias=float(row["bias"]), ssim=float(row["ssim"]))
            if row.get("bias_seeds") not in (None, "", "nan"):
                r["bias16"] = (float(row["bias_seeds"]), float(row["bias_se"]))
            if row["scene"] in data:
                preset = row["preset"]
                if row["model"] == "diffusion" and preset.endswith(" sweeps + FL"):  # e.g. "8 sweeps + FL"
                    r["sweeps"], preset = preset[: -len(" + FL")], "sweeps + FL"
                data[row["scene"]][(row["model"], preset)] = r
    return data


def _frames(v):
    return f"{v:.1f}" if v < 9.95 else f"{v:.0f}"


def _percent(b):
    s = f"{b * 100:+.0f}".replace("-", "−")
    return "0" if s in ("+0", "−0") else s


def table(data):
    """The Markdown table's lines."""
    best = {s: min(data[s][k]["block"] for _, k in ROWS if not k[0].startswith(("path", "progressive")))
            for s in SCENES}
    lines = ["| model | " + " | ".join(SCENES) + " | camera move | first frame |",
             "|---|---|---|---|---|---|"]
    for label, k in ROWS:
        cells = []
        for s in SCENES:
            r = data[s][k]
            if "bias16" in r:
                b, e = r["bias16"]
                bias = f"{b * 100:+.1f} ± {e * 100:.1f} %".replace("-", "−")
            else:
                bias = _percent(r["bias"]) + " %"
            block = f"{r['block']:.3f}"
            if round(r["block"], 3) == round(best[s], 3) and k[0] == "diffusion":
                block = f"**{block}**"
            cells.append(f"{block} ({bias}; {r['ssim']:.3f})")
        move = [data[s][k]["move"] for s in SCENES]
        first = [data[s][k]["first"] for s in SCENES]
        first_cell = "= move" if k[0].startswith("path_traced") else f"{_frames(min(first))}–{_frames(max(first))}"
        lines.append(f"| {label.format(**data[SCENES[0]][k])} | " + " | ".join(cells)
                     + f" | {_frames(min(move))}–{_frames(max(move))} | {first_cell} |")
    return lines


if __name__ == "__main__":
    print("\n".join(table(load(sys.argv[1] if len(sys.argv) > 1 else "benchmarks/results/trade.csv"))))
