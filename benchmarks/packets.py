"""The CPU camera pass's drivers and load policies (docs/performance.rst, "CPU camera pass").

Scene: ``benchmarks/speed.py``'s (the synthetic supernova, a table TF, half-voxel step), an
emission–absorption camera move. Each configuration runs in its own process (the load policy is
fixed when Numba is imported), the processes taken in turn, ``--rounds`` times; each times
``--frames`` camera moves after a warm-up pair; the table gives the median frame per thread count.

* packets, lane-by-lane loads: ``PV_AMBIENT_LANE_LOADS=1`` (``+prefer-no-gather`` on Zen 4/5);
* packets, Numba's loads: the default (hardware gathers where LLVM picks them; 512-bit vectors on
  the Intel CPUs of ``cpu_features.WIDE_CPUS``);
* packets, LLVM's vector width: ``PV_AMBIENT_WIDE_VECTORS=0`` (256 bits on Intel's AVX-512 CPUs);
* one ray at a time: ``PV_AMBIENT_PACKETS=0``, the per-pixel march (same sample function).

    python benchmarks/packets.py --n 256 --size 512
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

CONFIGS = [("packets, lane-by-lane loads", {"PV_AMBIENT_LANE_LOADS": "1"}), ("packets, Numba's loads (gathers)", {}),
           ("packets, LLVM's vector width", {"PV_AMBIENT_WIDE_VECTORS": "0"}),
           ("one ray at a time", {"PV_AMBIENT_PACKETS": "0"})]


def child(n, size, frames):
    """Time ``frames`` EA camera moves (after two warm-up frames); print the times and the policy."""
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import speed  # noqa: E402  (imports pv_ambient before Numba)
    from pv_ambient._kernels import packet
    from pv_ambient._kernels.cpu_features import load_policy

    fr = speed.make_frames(n, (size, size))
    fn = fr.frame_fn("camera", "EA")
    fn(0)
    fn(1)
    times = []
    for k in range(frames):
        t = time.perf_counter()
        fn(2 + k)
        times.append(time.perf_counter() - t)
    print("RESULT " + json.dumps(dict(times=times, policy=load_policy(), packets=packet.enabled())))


def run(n, size, frames, threads, env_extra):
    env = dict(os.environ, NUMBA_NUM_THREADS=str(threads), **env_extra)
    for var in ("NUMBA_CPU_FEATURES", "PV_AMBIENT_LANE_LOADS", "PV_AMBIENT_WIDE_VECTORS", "PV_AMBIENT_PACKETS"):
        if var not in env_extra:
            env.pop(var, None)
    proc = subprocess.run([sys.executable, __file__, "--child", "--n", str(n), "--size", str(size), "--frames",
                           str(frames)], env=env, capture_output=True, text=True, timeout=1800)
    if proc.returncode != 0:
        raise RuntimeError(proc.stderr[-3000:])
    line = [ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT ")][-1]
    return json.loads(line[len("RESULT "):])


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--n", type=int, default=256)
    p.add_argument("--size", type=int, default=512)
    p.add_argument("--frames", type=int, default=3)
    p.add_argument("--rounds", type=int, default=2)
    p.add_argument("--threads", default="1,2")
    p.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.child:
        child(args.n, args.size, args.frames)
        return
    import numpy as np

    threads = [int(t) for t in args.threads.split(",")]
    times = {(name, t): [] for name, _ in CONFIGS for t in threads}
    policies = {}
    for _ in range(args.rounds):
        for t in threads:
            for name, env in CONFIGS:
                out = run(args.n, args.size, args.frames, t, env)
                times[(name, t)] += out["times"]
                policies[name] = out["policy"]
    lines = [f"$ python benchmarks/packets.py --n {args.n} --size {args.size} --frames {args.frames} "
             f"--rounds {args.rounds} --threads {args.threads}", "",
             f"supernova {args.n}³, {args.size}x{args.size}, emission-absorption camera moves; median frame (s) of "
             f"{args.rounds} processes x {args.frames} frames per configuration", ""]
    head = f"{'configuration':36s}" + "".join(f"{str(t) + ' thread' + ('s' if t > 1 else ''):>12s}" for t in threads)
    lines += [head, "-" * len(head)]
    base = {t: float(np.median(times[(CONFIGS[-1][0], t)])) for t in threads}
    for name, _ in CONFIGS:
        cells = "".join(f"{np.median(times[(name, t)]):>7.3f} ({base[t] / np.median(times[(name, t)]):.2f}×)"
                        .rjust(12) for t in threads)
        lines.append(f"{name:36s}{cells}")
    lines += ["", "(×: speed-up over one ray at a time)", ""]
    lines += [f"{name}: loads {pol['loads']}, vectors {pol.get('width')} ({pol['why']})" for name, pol in policies.items()]
    print("\n".join(lines))


if __name__ == "__main__":
    main()
