"""Long-range multiple scattering by diffusion (docs/diffusion.rst): first-collision source → P1
(optionally flux-limited) diffusion solve on the data grid → fluence φ and flux F per channel.

The model
---------
Light that has scattered at least once is described by its fluence ``φ`` (W/m², the radiance
integrated over the sphere) and flux ``F`` (W/m², the first angular moment). From the light's
direct irradiance ``E_d`` (W/m², transmittance included) and unit propagation direction ``ω``
the first-collision source is ``Q0 = σs E_d`` and ``Q1 = g σs E_d ω`` (W/m³), and P1 reads

    ∇·F + σa φ = Q0,     F = −D ∇φ + 3 D Q1,     D = 1/(3 σt'),   σt' = σa + σs (1 − g).

Empty space gets a vacuum floor on σt' inside D (1/mean chord of the box, by default); a flux
limiter (Levermore–Pomraning, lagged coefficients) keeps ``|F| ≤ φ``. The camera pass adds
``σs (φ + 3 g F·ω_o) / (4π)`` per sample (ω_o toward the camera), φ and F trilinear.

The package
-----------
- :mod:`.medium`: :class:`DiffusionMedium`, σt and albedo checked once per scene;
- :mod:`.sources`: the direct irradiance per control volume and the first-collision source;
- :mod:`.system`: the node-centred finite-volume system (Marshak vacuum faces), the flux at the
  nodes and the power balance;
- :mod:`.multigrid`: the aggregation-multigrid hierarchy, V-cycle and preconditioned CG;
- :mod:`.limiter`: the flux limiter's coefficient, Anderson mixing and stopping measure;
- :mod:`.solve`: :func:`solve_diffusion` (vacuum floor, flux limiter with Anderson mixing,
  channel reuse), :func:`mean_chord` and the per-light entry point :func:`solve_for_light`,
  which takes arrays and small records — the caller computes the light's optical depth;
- :mod:`.solution`: :class:`DiffusionSolution` and :func:`camera_source`;
- :mod:`.ordinates`: the transport sweeps that carry the first scattering orders
  (``solve_for_light(sweep_orders=K)``, docs/diffusion.rst §5), with the hat-projected medium and
  first-collision source of :mod:`.sources` (:func:`hat_medium`, :func:`hat_source`).

Measured figures (errors against path tracing, iteration counts, times): docs/diffusion.rst.

This package imports numpy, scipy and the kernels only (no pyvista or vtk).
"""

from .medium import DiffusionMedium
from .solution import DiffusionSolution, camera_source
from .solve import mean_chord, solve_diffusion, solve_for_light, solve_in_medium
from .sources import direct_irradiance, first_collision_source, hat_medium, hat_source, source_in_medium

__all__ = [
    "DiffusionMedium",
    "DiffusionSolution",
    "camera_source",
    "direct_irradiance",
    "first_collision_source",
    "hat_medium",
    "hat_source",
    "mean_chord",
    "solve_diffusion",
    "solve_for_light",
    "solve_in_medium",
    "source_in_medium",
]
