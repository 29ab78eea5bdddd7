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
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from agvnav.world import load_map

__all__ = [
    "Anchor",
    "BaselineAnchor",
    "ScaleUnobservable",
    "StartPoseAnchor",
    "SurveyedAnchor",
    "anchor_kind",
    "apply_similarity",
    "fit_similarity",
    "match_surveyed",
    "parse_anchor",
]

F64 = NDArray[np.float64]

#: Survey std (m) of a surveyed reflector whose file does not state one.
DEFAULT_SURVEY_STD = 0.001


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
