"""Campaign files: one YAML document describing a Monte Carlo campaign (issue 11).

A campaign names a ``base`` scenario (a shipped name or a path relative to the
campaign file), fixed ``overrides`` for every run, the parameters to sweep
(``grid``: every combination of the listed values; ``random``: a fresh draw per
run from ``uniform``, ``normal`` or ``choice``), how many runs (``runs``, or
``seeds`` replicates per grid point), the ``metrics`` to collect (default all)
and the campaign ``seed`` from which every run's seed is derived. Parameters
are dotted scenario keys (``traction.speed_m_s``, ``path.segments.0.radius_m``); a fleet
scenario's size is ``fleet.size`` (its first N vehicles: :mod:`agvnav.campaign.overrides`).

The schema is strict and every error names the file, the line and the key
(:mod:`agvnav.world.strict`), e.g. ``sweep.yaml:9: grid.goniometer.p_miss[1]:
Input should be less than or equal to 1``: each override value is checked
against the scenario schema when the campaign is loaded, so a bad value is
reported at its own line in the campaign file, not half-way through the runs.
Random parameters are checked at their range ends (``uniform``), mean
(``normal``) or every value (``choice``); a ``normal`` draw beyond the scenario's
limits makes that run an ``error`` record naming the key.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from importlib import resources
from pathlib import Path
from typing import Annotated, Any

from pydantic import Field, model_validator

from agvnav.campaign.overrides import apply_overrides, dump_yaml, load_base, parse_document
from agvnav.campaign.task import METRIC_SECTIONS, is_metric_name, metric_names
from agvnav.world.scenario import KeyPath, ScenarioError, format_key, scenario_reference
from agvnav.world.strict import Finite, SourcedModel, StrictModel, load_yaml_document, validate_document

__all__ = ["CampaignSpec", "Distribution", "builtin_campaign_names", "is_number", "load_campaign", "parse_campaign"]

Scalar = bool | int | float | str | None
Value = Scalar | list[Any] | dict[str, Any]


class Distribution(StrictModel):
    """One random parameter: exactly one of ``uniform: [lo, hi]``, ``normal: [mu, sigma]``, ``choice: [...]``."""

    uniform: tuple[Finite, Finite] | None = None
    normal: tuple[Finite, Annotated[float, Field(gt=0.0, allow_inf_nan=False)]] | None = None
    choice: Annotated[list[Value], Field(min_length=1)] | None = None

    @model_validator(mode="after")
    def _exactly_one(self) -> Distribution:
        given = [k for k in ("uniform", "normal", "choice") if getattr(self, k) is not None]
        if len(given) != 1:
            raise ValueError("give exactly one of uniform: [lo, hi], normal: [mu, sigma], choice: [values]")
        if self.uniform is not None and not self.uniform[0] < self.uniform[1]:
            raise ValueError(f"uniform needs lo < hi, got {list(self.uniform)}")
        return self

    @property
    def kind(self) -> str:
        """``"uniform"``, ``"normal"`` or ``"choice"``."""
        return "uniform" if self.uniform is not None else ("normal" if self.normal is not None else "choice")

    def probe_values(self) -> list[Value]:
        """Values checked against the scenario schema at load time (range ends, mean, every choice)."""
        if self.uniform is not None:
            return list(self.uniform)
        if self.normal is not None:
            return [self.normal[0]]
        return list(self.choice or [])

    def is_numeric(self) -> bool:
        """True when every value this distribution yields is a real number (not a bool)."""
        return self.kind != "choice" or all(v is None or is_number(v) for v in self.choice or [])


def is_number(value: Any) -> bool:
    """True for int and float values, False for bool and everything else."""
    return isinstance(value, int | float) and not isinstance(value, bool)


DottedKey = Annotated[str, Field(pattern=r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z0-9_]+)*$")]


class CampaignSpec(SourcedModel):
    """A Monte Carlo campaign (see the module docstring)."""

    name: str = "campaign"
    description: str = ""
    base: str
    seed: Annotated[int, Field(ge=0)] = 0
    runs: Annotated[int, Field(ge=1)] | None = None
    seeds: Annotated[int, Field(ge=1)] | None = None
    common_seeds: bool = False
    overrides: dict[DottedKey, Value] = Field(default_factory=dict)
    grid: dict[DottedKey, Annotated[list[Value], Field(min_length=1)]] = Field(default_factory=dict)
    random: dict[DottedKey, Distribution] = Field(default_factory=dict)
    metrics: Annotated[list[str], Field(min_length=1)] | None = None

    @model_validator(mode="after")
    def _counts(self) -> CampaignSpec:
        if self.grid and self.runs is not None:
            raise ValueError("with a grid, give seeds (replicates per grid point), not runs")
        if not self.grid and (self.runs is None) == (self.seeds is None):
            raise ValueError("give runs: N (or seeds: N), or a grid")
        both = set(self.grid) & set(self.random)
        if both:
            raise ValueError(f"{sorted(both)[0]} is both in grid and in random")
        return self

    @property
    def replicates(self) -> int:
        """Runs per grid point (the whole campaign when there is no grid)."""
        return self.seeds or self.runs or 1

    @property
    def swept(self) -> list[str]:
        """The swept parameter keys: grid keys then random keys, in file order."""
        return [*self.grid, *self.random]

    def resolve_base(self) -> str:
        """The base scenario's file: a shipped name is the shipped scenario, whatever lies in the current
        folder; any other name a path relative to the campaign file's folder (:func:`scenario_reference`)."""
        try:
            return str(scenario_reference(self.base, self.base_dir))
        except ScenarioError:  # missing: load_base reports it, naming the base as written
            return self.base if self.base_dir is None else str(self.base_dir / self.base)


def parse_campaign(text: str, source: str = "<string>", base_dir: Path | None = None) -> CampaignSpec:
    """Parse and validate campaign YAML ``text`` and check every override against the base scenario.

    Raises
    ------
    ScenarioError
        Naming ``source``, the line and the key of the first problem.
    """
    data, nodes = load_yaml_document(text, source)
    spec = validate_document(CampaignSpec, data, nodes, source, base_dir)
    check_overrides(spec)
    return spec


def _campaigns_dir() -> Path:
    return Path(str(resources.files("agvnav") / "data" / "campaigns"))


def builtin_campaign_names() -> list[str]:
    """Names of the campaigns shipped in ``agvnav/data/campaigns``, sorted."""
    return sorted(p.stem for p in _campaigns_dir().glob("*.yaml"))


def load_campaign(path: str | Path) -> CampaignSpec:
    """Load and check a campaign file, or a shipped one by name (relative ``base`` paths: from its folder)."""
    p = Path(path)
    if not p.is_file() and p.suffix == "" and str(path) in builtin_campaign_names():
        p = _campaigns_dir() / f"{path}.yaml"
    if p.is_dir():
        raise ScenarioError("is a directory, not a campaign file", (), None, str(path))
    if not p.is_file():
        shipped = ", ".join(builtin_campaign_names())
        raise ScenarioError(f"no such campaign file (shipped campaigns: {shipped})", (), None, str(path))
    try:
        text = p.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise ScenarioError("is not a UTF-8 text file (a campaign is YAML text)", (), None, str(path)) from None
    return parse_campaign(text, source=str(path), base_dir=p.parent)


def _probes(spec: CampaignSpec) -> Iterator[tuple[KeyPath, str, Any]]:
    """``(campaign key path, dotted scenario key, value)`` of every override value to check."""
    for key, grid_values in spec.grid.items():
        for j, value in enumerate(grid_values):
            yield ("grid", key, j), key, value
    for key, dist in spec.random.items():
        for value in dist.probe_values():
            yield ("random", key, dist.kind), key, value


def check_overrides(spec: CampaignSpec) -> None:
    """Apply the fixed overrides, then each swept value alone, to the base; a bad one names its campaign line."""
    try:
        base = load_base(spec.resolve_base())
    except ScenarioError as exc:
        raise spec.error(("base",), f"{exc}") from None
    fixed = _validated(spec, base.mapping, spec.overrides, ("overrides",), base)
    for where, key, value in _probes(spec):
        _validated(spec, fixed, {key: value}, where, base)
    if spec.metrics is not None:
        unknown = [m for m in spec.metrics if not is_metric_name(m)]
        if unknown:
            j = spec.metrics.index(unknown[0])
            known = ", ".join([*metric_names(), *(f"{s}.<name>" for s in METRIC_SECTIONS)])
            raise spec.error(("metrics", j), f"unknown metric {unknown[0]!r}; known: {known}")


def _validated(
    spec: CampaignSpec, mapping: Mapping[str, Any], overrides: Mapping[str, Any], where: KeyPath, base: Any
) -> dict[str, Any]:
    """``mapping`` with ``overrides`` applied, checked with ``parse_scenario``; errors located in the campaign."""
    try:
        merged = apply_overrides(mapping, overrides)
        parse_document(dump_yaml(merged), source=base.source, base_dir=base.base_dir)
    except ScenarioError as exc:
        raise _relocate(spec, exc, overrides, where) from None
    except ValueError as exc:  # a dotted key that cannot be set
        raise spec.error(where, str(exc)) from None
    return merged


def _relocate(spec: CampaignSpec, exc: ScenarioError, overrides: Mapping[str, Any], where: KeyPath) -> ScenarioError:
    """Report a scenario error caused by an override at that override's line in the campaign file."""
    dotted = ".".join(str(p) for p in exc.key)
    for key in overrides:
        if dotted == key or dotted.startswith(key + ".") or key.startswith(dotted + ".") or not dotted:
            loc = (*where, key) if where == ("overrides",) else where
            detail = exc.detail if dotted == key else f"{format_key(exc.key) or 'scenario'}: {exc.detail}"
            return ScenarioError(detail, loc, spec.locate(loc), spec.source)
    return spec.error(where, f"with this value the base scenario is invalid: {exc}")
