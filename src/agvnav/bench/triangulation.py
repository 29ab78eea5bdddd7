"""``agvnav bench triangulation``: speed and accuracy of the four triangulation methods.

Per method: ns per fix over a batch of 1e6 fixes (1e5 with ``--quick``), µs per single fix
through the public API, peak memory of the batch call, and RMS position/heading error over a workspace grid with
the seed's goniometer (65535 pulses/rev, bearings quantised to the pulse) against the
CRLB of that quantisation noise (seed 000, §4.1).

The speed baseline is a small C implementation of ToTal written here from the same
equations as ``agvnav.positioning.total`` (same outputs: position and the circular-mean
heading), compiled with gcc at bench time into a temporary directory and loaded with
ctypes, so the comparison is on the same machine: ``c_total_ns_per_fix`` computes the
same outputs as ours (position and heading), ``c_total_position_only_ns_per_fix`` only
the position (as usually quoted for ToTal). Without gcc the C columns are None and the
note says why. Each method's batch is timed interleaved with both C variants (alternating
rounds, best of each: 7 rounds, 3 with ``--quick``), so load on a shared machine hits
both sides of a ratio alike; ``batch_over_c_total`` compares with the same-output C,
``batch_over_c_position_only`` with the position-only figure usually quoted (~45 ns).
"""

from __future__ import annotations

import ctypes
import math
import shutil
import subprocess
import tempfile
import tracemalloc
from pathlib import Path
from typing import Any

import numpy as np

from agvnav.bench.common import best_time
from agvnav.geometry import angle_diff, bearing_to
from agvnav.positioning import METHODS, crlb, encoder_bearing_std, triangulate

TITLE = "Triangulation: ns/fix (batch 1e6), µs/single fix, RMS error vs CRLB (65535 pulses/rev)"
#: Columns a narrow terminal keeps, most important first (`--wide` shows all).
PRIORITY = (
    "method", "reflectors", "rms_position_m", "crlb_rms_position_m", "batch_ns_per_fix", "single_us_per_fix",
    "rms_heading_rad",
)

PULSES_PER_REV = 65535
#: Seed-like layout: three reflectors on a 10 m circle (the critical circle), workspace inside it.
REFLECTORS_3 = np.array([[0.0, 10.0], [-10.0 * math.sqrt(3) / 2, -5.0], [10.0 * math.sqrt(3) / 2, -5.0]])
#: Two more reflectors for the N > 3 least-squares row.
REFLECTORS_5 = np.vstack([REFLECTORS_3, [[-9.0, 6.0], [9.0, 6.5]]])

C_SOURCE = r"""
#include <math.h>
static const double PI = 3.141592653589793, TWO_PI = 6.283185307179586;
/* agvnav.geometry.wrap_angle_scalar: [-pi, pi), exact (fmod, then one Sterbenz-exact step) */
static double wrap(double a) {
    double r = fmod(a, TWO_PI);
    return r >= PI ? r - TWO_PI : (r < -PI ? r + TWO_PI : r);
}

/* ToTal (Pierlot & Van Droogenbroeck 2014) for n fixes with one layout r[6] = x1 y1 x2 y2 x3 y3.
   theta[3n] bearings; out[3n] = x, y, heading (heading only if with_heading). The pair most
   nearly aligned with P is put last (3, 1) and T31 is kept as a fraction, as in
   agvnav.positioning.total (which reorders only below |tan| 0.25; same result). */
void total_batch(const double *r, const double *theta, double *out, long n, int with_heading) {
    for (long k = 0; k < n; ++k) {
        const double *t = theta + 3 * k;
        double t12 = tan(t[1] - t[0]), t23 = tan(t[2] - t[1]), t31 = tan(t[0] - t[2]);
        int o0 = 0, o1 = 1, o2 = 2;
        double a12 = fabs(t12), a23 = fabs(t23), a31 = fabs(t31), ta = t12, tb = t23;
        if (a12 < a23 && a12 < a31) { o0 = 1; o1 = 2; o2 = 0; ta = t23; tb = t31; }
        else if (a23 <= a12 && a23 < a31) { o0 = 2; o1 = 0; o2 = 1; ta = t31; tb = t12; }
        double x1 = r[2*o0] - r[2*o1], y1 = r[2*o0+1] - r[2*o1+1];
        double x3 = r[2*o2] - r[2*o1], y3 = r[2*o2+1] - r[2*o1+1];
        double c12 = 1.0 / ta, c23 = 1.0 / tb;
        double nn = 1.0 - c12 * c23, d = c12 + c23;
        double x12 = x1 + c12 * y1, y12 = y1 - c12 * x1;
        double x23 = x3 - c23 * y3, y23 = y3 + c23 * x3;
        double dx31 = d * (x3 + x1) + nn * (y3 - y1);
        double dy31 = d * (y3 + y1) - nn * (x3 - x1);
        double dk31 = d * (x1 * x3 + y1 * y3) + nn * (x1 * y3 - x3 * y1);
        double a = y12 - y23, b = x23 - x12;
        double dd = (x12 - x23) * (d * y23 - dy31) - a * (d * x23 - dx31);
        double f = dk31 / dd;
        double px = r[2*o1] + f * a, py = r[2*o1+1] + f * b;
        out[3*k] = px; out[3*k+1] = py;
        if (with_heading) {
            double h0 = atan2(r[1] - py, r[0] - px) - t[0];
            double h1 = atan2(r[3] - py, r[2] - px) - t[1];
            double h2 = atan2(r[5] - py, r[4] - px) - t[2];
            out[3*k+2] = wrap(h0 + (wrap(h1 - h0) + wrap(h2 - h0)) / 3.0);
        }
    }
}
"""


def _compile_c_total(workdir: Path) -> tuple[Any, str]:
    """Compile the C ToTal into ``workdir``; returns (function or None, note)."""
    gcc = shutil.which("gcc")
    if gcc is None:
        return None, "gcc not found: no C baseline"
    src = workdir / "total.c"
    lib = workdir / "libtotal.so"
    src.write_text(C_SOURCE)
    flags = ["-O3", "-march=native", "-fPIC", "-shared"]
    proc = subprocess.run([gcc, *flags, str(src), "-o", str(lib), "-lm"], capture_output=True, text=True)
    if proc.returncode != 0:
        return None, f"gcc failed: {proc.stderr.strip()[:200]}"
    fn = ctypes.CDLL(str(lib)).total_batch
    fn.restype = None
    ptr = ctypes.POINTER(ctypes.c_double)
    fn.argtypes = [ptr, ptr, ptr, ctypes.c_long, ctypes.c_int]
    return fn, "gcc " + " ".join(flags[:2])


def _c_call(fn: Any, bearings: np.ndarray, truth: np.ndarray, with_heading: bool) -> Any:
    """A zero-argument call of the C ToTal over the whole batch, checked once against the truth."""
    r = np.ascontiguousarray(REFLECTORS_3.ravel())
    th = np.ascontiguousarray(bearings)
    out = np.zeros_like(th)
    ptr = ctypes.POINTER(ctypes.c_double)

    def call() -> None:
        fn(r.ctypes.data_as(ptr), th.ctypes.data_as(ptr), out.ctypes.data_as(ptr), th.shape[0], int(with_heading))

    call()
    err = np.max(np.abs(out[:, :2] - truth[:, :2]))  # the C code must actually solve the fix
    if with_heading:
        err = max(err, float(np.max(np.abs(angle_diff(out[:, 2], truth[:, 2])))))
    if not err < 1e-6:
        raise RuntimeError(f"C ToTal disagrees with the truth by {err}")
    return call


def interleaved_best(funcs: list[Any], rounds: int) -> list[float]:
    """Best wall time (s) of each function, timed alternately ``rounds`` times.

    Alternating (C, NumPy, C, NumPy, ...) exposes every candidate to the same load on a
    shared machine, so a burst of load cannot bias the ratio the way back-to-back runs do.
    """
    best = [math.inf] * len(funcs)
    for _ in range(rounds):
        for i, f in enumerate(funcs):
            best[i] = min(best[i], best_time(f, repeat=1))
    return best


def _random_poses(n: int, rng: np.random.Generator) -> np.ndarray:
    """Poses uniformly in the disc of radius 7 m (inside the 10 m critical circle)."""
    rad = 7.0 * np.sqrt(rng.uniform(0, 1, n))
    ang = rng.uniform(-math.pi, math.pi, n)
    return np.stack([rad * np.cos(ang), rad * np.sin(ang), rng.uniform(-math.pi, math.pi, n)], axis=-1)


def _quantise(bearings: np.ndarray) -> np.ndarray:
    step = 2.0 * math.pi / PULSES_PER_REV
    return np.round(bearings / step) * step


def _grid(quick: bool, rng: np.random.Generator) -> np.ndarray:
    """Workspace grid (step 0.25 m, 0.5 m quick) inside 70 % of the critical circle, random headings."""
    step = 0.5 if quick else 0.25
    g = np.arange(-7.0, 7.0 + 1e-9, step)
    xx, yy = np.meshgrid(g, g)
    keep = np.hypot(xx, yy) <= 7.0
    xy = np.stack([xx[keep], yy[keep]], axis=-1)
    xy = xy[np.min(np.linalg.norm(xy[:, None, :] - REFLECTORS_5[None], axis=-1), axis=1) > 0.5]
    heading = rng.uniform(-math.pi, math.pi, len(xy))
    return np.concatenate([xy, heading[:, None]], axis=-1)


def _accuracy(method: str, reflectors: np.ndarray, grid: np.ndarray, rng: np.random.Generator) -> dict[str, float]:
    sigma = encoder_bearing_std(PULSES_PER_REV)
    bearings = _quantise(bearing_to(grid[:, None, :], reflectors))
    heading_estimate = grid[:, 2] + rng.normal(0.0, math.radians(2.0), len(grid))
    fix = triangulate(reflectors, bearings, method, heading_estimate=heading_estimate)
    ok = fix.valid
    pos2 = (fix.x - grid[:, 0]) ** 2 + (fix.y - grid[:, 1]) ** 2
    head2 = angle_diff(fix.heading, grid[:, 2]) ** 2
    bound = crlb(reflectors, grid, sigma)
    return {
        "rms_position_m": float(np.sqrt(np.mean(pos2[ok]))),
        "rms_heading_rad": float(np.sqrt(np.mean(head2[ok]))),
        "crlb_rms_position_m": float(np.sqrt(np.mean(bound[ok, 0, 0] + bound[ok, 1, 1]))),
        "crlb_rms_heading_rad": float(np.sqrt(np.mean(bound[ok, 2, 2]))),
        "valid_fraction": float(np.mean(ok)),
    }


def _speed(method: str, reflectors: np.ndarray, n_batch: int, rng: np.random.Generator,
           c_calls: list[Any], rounds: int) -> dict[str, Any]:
    """Batch ns/fix interleaved with the C calls (same rounds), single-fix µs, peak memory."""
    poses = _random_poses(n_batch, rng)
    bearings = bearing_to(poses[:, None, :], reflectors)
    heading_estimate = poses[:, 2] + 0.05
    times = interleaved_best(
        [lambda: triangulate(reflectors, bearings, method, heading_estimate=heading_estimate), *c_calls], rounds
    )
    tracemalloc.start()
    triangulate(reflectors, bearings, method, heading_estimate=heading_estimate)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    one_b, one_h = bearings[0], float(heading_estimate[0])
    single = best_time(lambda: triangulate(reflectors, one_b, method, heading_estimate=one_h), repeat=5, number=200)
    rec: dict[str, Any] = {
        "batch_ns_per_fix": times[0] / n_batch * 1e9,
        "single_us_per_fix": single * 1e6,
        "batch_fixes": n_batch,
        "peak_mib": peak / 2**20,  # tracemalloc peak during the batch call, inputs excluded
        "c_total_ns_per_fix": None,
        "c_total_position_only_ns_per_fix": None,
    }
    if c_calls:
        rec["c_total_ns_per_fix"] = times[1] / n_batch * 1e9
        rec["c_total_position_only_ns_per_fix"] = times[2] / n_batch * 1e9
    return rec


def run(quick: bool, seed: int) -> list[dict[str, Any]]:
    """One record per method (plus least squares over five reflectors); see the module docstring."""
    rng = np.random.default_rng(seed)
    n_batch = 100_000 if quick else 1_000_000
    grid = _grid(quick, rng)
    rounds = 3 if quick else 7
    records: list[dict[str, Any]] = []
    rows = [(m, m, REFLECTORS_3) for m in METHODS] + [("least_squares_5", "least_squares", REFLECTORS_5)]
    with tempfile.TemporaryDirectory() as tmp:
        fn, note = _compile_c_total(Path(tmp))
        c_calls: list[Any] = []
        if fn is not None:
            poses = _random_poses(n_batch, rng)
            bearings = bearing_to(poses[:, None, :], REFLECTORS_3)
            c_calls = [_c_call(fn, bearings, poses, True), _c_call(fn, bearings, poses, False)]
        for name, method, refl in rows:
            rec: dict[str, Any] = {"method": name, "reflectors": len(refl),
                                   **_speed(method, refl, n_batch, rng, c_calls, rounds)}
            rec.update(_accuracy(method, refl, grid, rng))
            rec["rms_over_crlb"] = rec["rms_position_m"] / rec["crlb_rms_position_m"]
            c_ns, c_pos = rec["c_total_ns_per_fix"], rec["c_total_position_only_ns_per_fix"]
            rec["batch_over_c_total"] = None if c_ns is None else rec["batch_ns_per_fix"] / c_ns
            rec["batch_over_c_position_only"] = None if c_pos is None else rec["batch_ns_per_fix"] / c_pos
            rec["note"] = note if method == "total" else ""
            records.append(rec)
    return records
