"""Monte Carlo campaigns (issue 11): many seeded runs of one base scenario on a Dask cluster.

``load_campaign`` reads a campaign file (:mod:`agvnav.campaign.spec`);
``plan_runs`` derives every run's swept values and seed from the campaign seed;
``run_campaign`` runs them on a ``distributed`` cluster, streaming the results
to a resumable Parquet dataset, and writes ``summary.json``;
``write_replay`` writes one run's whole scenario for ``agvnav simulate``.
Dask and pyarrow are the optional ``campaign`` extra: ``pip install agvnav[campaign]``.
Importing this package does not need them: the campaign file, the plan, the overrides and
the task (what ``agvnav bench mapping`` uses) import without; the names of
:mod:`~agvnav.campaign.runner`, :mod:`~agvnav.campaign.store` and :mod:`~agvnav.campaign.summary`
are imported on first use, and raise ``ModuleNotFoundError`` (``dask``, ``distributed`` or
``pyarrow``) there when the extra is missing.
"""

import importlib
from typing import TYPE_CHECKING, Any

from agvnav.campaign.overrides import BaseScenario, apply_overrides, load_base, set_dotted
from agvnav.campaign.plan import RunPlan, plan_runs, run_seed
from agvnav.campaign.spec import CampaignSpec, Distribution, load_campaign, parse_campaign
from agvnav.campaign.task import metric_names, run_batch, run_one, simulate_metrics

if TYPE_CHECKING:
    from agvnav.campaign.runner import CampaignResult, run_campaign, write_replay
    from agvnav.campaign.store import finished_runs, read_results
    from agvnav.campaign.summary import describe, summarize

#: Names that need the campaign extra, and their module (imported on first use: :func:`__getattr__`).
_NEEDS_EXTRA = {
    "CampaignResult": "runner", "run_campaign": "runner", "write_replay": "runner",
    "finished_runs": "store", "read_results": "store", "describe": "summary", "summarize": "summary",
}


def __getattr__(name: str) -> Any:
    """The names of the modules that need Dask or pyarrow, imported when first asked for."""
    module = _NEEDS_EXTRA.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value

__all__ = [
    "BaseScenario",
    "CampaignResult",
    "CampaignSpec",
    "Distribution",
    "RunPlan",
    "apply_overrides",
    "describe",
    "finished_runs",
    "load_base",
    "load_campaign",
    "metric_names",
    "parse_campaign",
    "plan_runs",
    "read_results",
    "run_batch",
    "run_campaign",
    "run_one",
    "run_seed",
    "set_dotted",
    "simulate_metrics",
    "summarize",
    "write_replay",
]
