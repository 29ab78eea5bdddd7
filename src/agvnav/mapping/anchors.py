"""What fixes a bearing-only map's frame and scale: the anchors a site has.

Bearings carry no scale, and a map drawn from them and odometry has a free frame (3
degrees of freedom) and a scale only as good as the odometry's calibration. The anchors:

- :class:`SurveyedAnchor`: two or more reflectors surveyed in the site frame. They fix
  frame and scale (the odometry scale is then estimated); the mapped reflectors are
  matched to them by their mutual distances (:func:`match_surveyed`).
- :class:`BaselineAnchor`: a taped distance between two reflectors, named by their
  approximate positions in the start-pose frame. It fixes the scale; the frame is the
  start pose (the log's, or a :class:`StartPoseAnchor`).
- :class:`StartPoseAnchor`: a known start pose, and the odometry's calibrated scale
  (``scale ± scale_std``). Frame from the pose, scale from the odometry.

With none, :class:`ScaleUnobservable` (a ValueError) is raised instead of a confident map.

Command-line forms (:func:`parse_anchor`): ``surveyed:FILE.yaml`` (a map of the surveyed
reflectors; ``survey_std_m`` each, default 1 mm), ``baseline:X1,Y1,X2,Y2,D[,STD_MM]`` (m, m,
m, m, m, mm; default 1 mm), ``start_pose[:X,Y,HEADING_DEG]`` (default: the log's start).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from agvnav.world import load_map

if TYPE_CHECKING:
    from agvnav.mapping.slam import MappingResult

__all__ = [
    "MAX_ANCHOR_SIGMA",
    "MAX_SCALE_ERROR",
    "MIN_REDUNDANCY",
    "SCALE_SIGNIFICANCE",
    "Anchor",
    "AnchorImplausible",
    "BaselineAnchor",
    "ScaleUnobservable",
    "StartPoseAnchor",
    "SurveyedAnchor",
    "anchor_kind",
    "apply_similarity",
    "check_anchor_fit",
    "fit_similarity",
    "match_surveyed",
    "parse_anchor",
]

F64 = NDArray[np.float64]

#: Survey std (m) of a surveyed reflector whose file does not state one.
DEFAULT_SURVEY_STD = 0.001


#: Largest relative error of the wheel odometry's distance scale that anchors may imply (2 %). A wheel's
#: effective radius moves with tyre wear, load and pressure by a few tenths of a percent (polyurethane AGV
#: wheels, rubber tyres: 0.1-1 %; the shipped vehicles' 0.2 % wheel error; seed 004's tracks, the worst
#: case, about 1 %), and a commissioned vehicle's odometry is calibrated to that. A map whose anchors need
#: the odometry 2 % off is far likelier anchored by the wrong reflectors (another site's survey, a survey
#: in other units or frame, a mistyped baseline) than driven by such a vehicle; ``--max-scale-error``
#: raises the limit for one that really is (an uncalibrated prototype).
MAX_SCALE_ERROR = 0.02

#: A scale error beyond :data:`MAX_SCALE_ERROR` counts only when it is also this many of its own std
#: from nominal: a drive too short to fix the scale is reported by its std, not refused by chance.
SCALE_SIGNIFICANCE = 3.0

#: Largest normalised residual (sigma, 2-D) of a surveyed reflector: how far the drive puts it from its
#: surveyed position, against the survey std and the map's own covariance there (the residual covariance
#: ``σ²I - C_j`` of a prior [Baarda's w-test]). Its square is chi-square with 2 dof for a correct survey:
#: beyond 5 sigma happens 4 in a million times, while a surveyed reflector swapped, misplaced by a few
#: centimetres or taken from another site lands tens of sigma off.
MAX_ANCHOR_SIGMA = 5.0


class AnchorImplausible(ValueError):
    """The anchors contradict the drive (an implausible odometry scale, a surveyed reflector far off)."""


class ScaleUnobservable(ValueError):
    """The map has no anchor: bearings and odometry alone leave its scale (and frame) unobservable."""


@dataclass(frozen=True)
class SurveyedAnchor:
    """Surveyed reflectors: ids ``(n,)``, centres ``xy (n, 2)`` (m, site frame), std ``(n,)`` (m per axis)."""

    ids: tuple[str, ...]
    xy: F64
    std: F64

    def __post_init__(self) -> None:
        xy = np.asarray(self.xy, dtype=np.float64).reshape(-1, 2)
        std = np.broadcast_to(np.asarray(self.std, dtype=np.float64), (xy.shape[0],)).copy()
        if xy.shape[0] < 2 or len(self.ids) != xy.shape[0]:
            raise ValueError(f"a surveyed anchor needs two or more reflectors with ids, got {xy.shape[0]}")
        if not (np.all(np.isfinite(xy)) and np.all(std > 0.0)):
            raise ValueError("surveyed reflectors need finite positions and a positive survey std")
        object.__setattr__(self, "xy", xy)
        object.__setattr__(self, "std", std)


@dataclass(frozen=True)
class BaselineAnchor:
    """A taped distance ``distance`` (m, std ``std`` m) between the reflectors nearest ``first``/``second``.

    ``first``, ``second``: approximate centres (m) in the map's frame (the start-pose frame), matched
    to mapped reflectors within ``match_radius`` (m).
    """

    first: tuple[float, float]
    second: tuple[float, float]
    distance: float
    std: float = 0.001
    match_radius: float = 0.5

    def __post_init__(self) -> None:
        if not (math.isfinite(self.distance) and self.distance > 0.0):
            raise ValueError(f"the baseline distance must be positive, got {self.distance!r}")
        if not (math.isfinite(self.std) and self.std > 0.0):
            raise ValueError(f"the baseline std must be positive, got {self.std!r}")


@dataclass(frozen=True)
class StartPoseAnchor:
    """A known start pose ``pose`` (m, m, rad; None: the log's) with std ``pose_std`` (m, m, rad), and the
    odometry's calibrated scale ``scale`` with std ``scale_std`` (relative)."""

    pose: tuple[float, float, float] | None = None
    pose_std: tuple[float, float, float] = (0.001, 0.001, math.radians(0.05))
    scale: float = 1.0
    scale_std: float = 0.002

    def __post_init__(self) -> None:
        if not (all(math.isfinite(v) and v > 0.0 for v in self.pose_std) and self.scale_std > 0.0
                and math.isfinite(self.scale) and self.scale > 0.0):
            raise ValueError("a start-pose anchor needs positive stds and a positive scale")


Anchor = SurveyedAnchor | BaselineAnchor | StartPoseAnchor


def anchor_kind(anchors: tuple[Anchor, ...] | list[Anchor]) -> str:
    """A short name of the anchors (``surveyed2``, ``baseline``, ``start_pose``, joined by ``+``), or ``none``."""
    names = []
    for a in anchors:
        if isinstance(a, SurveyedAnchor):
            names.append(f"surveyed{len(a.ids)}")
        elif isinstance(a, BaselineAnchor):
            names.append("baseline")
        else:
            names.append("start_pose")
    return "+".join(names) or "none"


def _floats(text: str, n_min: int, n_max: int, what: str) -> list[float]:
    try:
        vals = [float(v) for v in text.split(",")]
    except ValueError:
        raise ValueError(f"anchor {what}: expected comma-separated numbers, got {text!r}") from None
    if not n_min <= len(vals) <= n_max or not all(math.isfinite(v) for v in vals):
        raise ValueError(f"anchor {what}: expected {n_min}-{n_max} finite numbers, got {text!r}")
    return vals


def parse_anchor(text: str) -> Anchor:
    """An anchor from its command-line form (module docstring); ValueError names the problem."""
    kind, _, rest = text.strip().partition(":")
    if kind == "surveyed":
        if not rest:
            raise ValueError("anchor surveyed: needs a map file of the surveyed reflectors (surveyed:FILE.yaml)")
        world = load_map(Path(rest))
        std = np.where(world.reflector_survey_std > 0.0, world.reflector_survey_std, DEFAULT_SURVEY_STD)
        return SurveyedAnchor(world.reflector_ids, world.reflector_xy.copy(), std)
    if kind == "baseline":
        v = _floats(rest, 5, 6, "baseline:X1,Y1,X2,Y2,D[,STD_MM]")
        return BaselineAnchor((v[0], v[1]), (v[2], v[3]), v[4], v[5] / 1000.0 if len(v) == 6 else 0.001)
    if kind == "start_pose":
        if not rest:
            return StartPoseAnchor()
        v = _floats(rest, 3, 3, "start_pose:X,Y,HEADING_DEG")
        return StartPoseAnchor((v[0], v[1], math.radians(v[2])))
    raise ValueError(f"unknown anchor {text!r}: use surveyed:FILE.yaml, baseline:X1,Y1,X2,Y2,D[,STD_MM] "
                     "or start_pose[:X,Y,HEADING_DEG]")


def match_surveyed(mapped: F64, surveyed: F64, tolerance: float = 0.2,
                   scale_tolerance: float = 0.03) -> tuple[NDArray[np.int64], F64]:
    """Match surveyed reflectors ``(S, 2)`` to mapped ones ``(N, 2)`` in another frame, by their distances.

    Every pair of surveyed reflectors is tried against every pair of mapped ones whose
    distance agrees within ``scale_tolerance`` (relative) plus ``tolerance``; each gives a
    similarity transform (rotation, translation, scale), and the one that brings the most
    surveyed reflectors within ``tolerance`` (m) of a mapped one wins; among equals, the one that
    moves the mapped points least (with two surveyed reflectors every pair at their distance
    matches, and the provisional map is in the start pose's frame, usually close to the site's).

    Returns ``(index (S,), T)``: the mapped row of each surveyed reflector (-1: unmatched) and
    ``T = [a, b, tx, ty]`` mapping a mapped point ``p`` to ``[[a, -b], [b, a]] p + t`` in the
    surveyed frame. ValueError if fewer than two match.
    """
    S, N = surveyed.shape[0], mapped.shape[0]
    best: tuple[int, float, NDArray[np.int64], F64] | None = None
    for i in range(S):
        for j in range(i + 1, S):
            ds = float(np.hypot(*(surveyed[j] - surveyed[i])))
            for k in range(N):
                for m in range(N):
                    if k == m:
                        continue
                    dm = float(np.hypot(*(mapped[m] - mapped[k])))
                    if abs(dm - ds) > scale_tolerance * ds + tolerance or dm <= 0.0:
                        continue
                    T = fit_similarity(mapped[[k, m]], surveyed[[i, j]])
                    moved = apply_similarity(T, mapped)
                    d = np.hypot(*(surveyed[:, None, :] - moved[None, :, :]).transpose(2, 0, 1))
                    idx = np.argmin(d, axis=1)
                    ok = d[np.arange(S), idx] <= tolerance
                    idx = np.where(ok, idx, -1)
                    # ties (two surveyed reflectors match any pair at their distance): the transform
                    # that moves the provisional map least (its frame is the start pose's) wins
                    move = float(np.sum(np.hypot(*(moved - mapped).T)))
                    score = (int(ok.sum()), -move)
                    if best is None or score > (best[0], best[1]):
                        best = (score[0], score[1], idx.astype(np.int64), T)
    if best is None or best[0] < 2:
        raise ValueError(f"fewer than two of the {S} surveyed reflectors match a mapped one (within {tolerance} m "
                         "after a similarity transform): check the surveyed file's frame and ids")
    idx = best[2]
    use = idx >= 0
    if len(set(idx[use].tolist())) != int(use.sum()):
        raise ValueError("two surveyed reflectors match the same mapped reflector")
    return idx, fit_similarity(mapped[idx[use]], surveyed[use])


def fit_similarity(src: F64, dst: F64) -> F64:
    """Least-squares similarity ``[a, b, tx, ty]`` with ``dst ≈ [[a, -b], [b, a]] src + t`` (Umeyama, 2-D), from
    matched points ``src``, ``dst`` ``(n, 2)`` (m), ``n >= 2``."""
    ms, md = src.mean(axis=0), dst.mean(axis=0)
    s0, d0 = src - ms, dst - md
    den = float(np.sum(s0 * s0))
    a = float(np.sum(s0 * d0)) / den
    b = float(np.sum(s0[:, 0] * d0[:, 1] - s0[:, 1] * d0[:, 0])) / den
    t = md - np.array([a * ms[0] - b * ms[1], b * ms[0] + a * ms[1]])
    return np.array([a, b, t[0], t[1]])


def apply_similarity(T: F64, p: F64) -> F64:
    """Points ``(n, 2)`` moved by the similarity ``T = [a, b, tx, ty]`` of :func:`match_surveyed`."""
    a, b, tx, ty = T
    return np.column_stack([a * p[:, 0] - b * p[:, 1] + tx, b * p[:, 0] + a * p[:, 1] + ty])


#: Least local redundancy (Baarda: the residual's variance over the observation's, 0-1) of a direction of a
#: surveyed reflector's residual that is tested: below it the drive cannot check the survey there (two
#: surveyed reflectors fix the frame's four degrees of freedom and nothing else, so their residual is
#: noise of the solution, not a test).
MIN_REDUNDANCY = 0.01


def _residual_sigma(r: F64, std: float, cov: F64) -> float:
    """The normalised 2-D residual ``sqrt(rᵀ Q⁻¹ r)`` of a surveyed reflector, ``Q = std² I - cov`` (m²).

    ``r`` (m): mapped minus surveyed position; ``std`` (m per axis): the survey's; ``cov`` (m²): the
    map's covariance of the reflector. Only the directions of ``Q`` with a local redundancy of at least
    :data:`MIN_REDUNDANCY` count (0 when none has).
    """
    w, v = np.linalg.eigh(std * std * np.eye(2) - 0.5 * (cov + cov.T))
    z = v.T @ r
    test = w >= MIN_REDUNDANCY * std * std
    return float(math.sqrt(float(np.sum(z[test] ** 2 / w[test]))))


def check_anchor_fit(
    result: MappingResult,
    anchors: Sequence[Anchor],
    labels: Sequence[str] | None = None,
    max_scale_error: float = MAX_SCALE_ERROR,
    max_sigma: float = MAX_ANCHOR_SIGMA,
    existing_label: str | None = None,
) -> None:
    """Raise :class:`AnchorImplausible` when the anchors of a solved map contradict its drive.

    Two tests, each naming the anchor (``labels[i]`` for ``anchors[i]``, default its kind):

    - **scale**: the odometry scale the map implies (``result.scale ± result.scale_std``) differs from
      nominal (a start-pose anchor's calibrated scale, else 1) by more than ``max_scale_error``
      (relative; :data:`MAX_SCALE_ERROR`) and by more than :data:`SCALE_SIGNIFICANCE` of its std. The
      anchors that set the scale are named: surveyed and baseline ones, and the existing map
      (``existing_label``). Anchors from another site that differ from the right ones by a similarity
      (shift, rotation, scale) leave no residual; only their scale gives them away.
    - **residuals**: a surveyed reflector the map puts more than ``max_sigma``
      (:data:`MAX_ANCHOR_SIGMA`) normalised residuals from its surveyed position (:func:`_residual_sigma`;
      with three or more surveyed reflectors: two only fix the frame, and leave nothing to test).

    A frame that is only shifted and rotated is not detectable from the drive: bearings and odometry
    carry no absolute position or heading.
    """
    anchors = list(anchors)
    names = list(labels) if labels is not None else [anchor_kind([a]) for a in anchors]
    if len(names) != len(anchors):
        raise ValueError(f"need one label per anchor, got {len(names)} for {len(anchors)}")
    starts = [a for a in anchors if isinstance(a, StartPoseAnchor)]
    nominal = starts[0].scale if starts else 1.0
    error = result.scale / nominal - 1.0
    setters = [n for a, n in zip(anchors, names, strict=True) if isinstance(a, SurveyedAnchor | BaselineAnchor)]
    if existing_label is not None and result.existing_ids:
        setters.append(existing_label)
    std = result.scale_std / nominal
    if setters and abs(error) > max_scale_error and not abs(error) <= SCALE_SIGNIFICANCE * std:
        raise AnchorImplausible(
            f"{' and '.join(setters)}: the anchors imply an odometry scale of {result.scale:.5f} ± "
            f"{result.scale_std:.5f}, {error * 100:+.1f} % from {nominal:g}, beyond the {max_scale_error * 100:g} % "
            "of wheel odometry: check the anchors are this site's, in metres (--max-scale-error to allow more)"
        )
    ids = list(result.ids)
    for a, name in zip(anchors, names, strict=True):
        if not isinstance(a, SurveyedAnchor):
            continue
        worst: tuple[float, str, float] | None = None
        for rid, xy, s in zip(a.ids, a.xy, a.std, strict=True):
            if rid not in ids:
                continue
            j = ids.index(rid)
            r = np.asarray(result.xy[j], dtype=np.float64) - xy
            w = _residual_sigma(r, float(s), np.asarray(result.covariance[j], dtype=np.float64))
            if worst is None or w > worst[0]:
                worst = (w, rid, float(np.hypot(*r)))
        if worst is not None and worst[0] > max_sigma:
            raise AnchorImplausible(
                f"{name}: surveyed reflector {worst[1]} is {worst[2] * 1000:.1f} mm ({worst[0]:.1f} sigma) from "
                f"where the drive puts it, beyond {max_sigma:g} sigma: check its surveyed position and id"
            )
