"""Monte Carlo campaigns (issue 11): many seeded runs of one base scenario on a Dask cluster.

``load_campaign`` reads a campaign file (:mod:`agvnav.campaign.spec`);
``plan_runs`` derives every run's swept values and seed from the campaign seed;
``run_campaign`` runs them on a ``distributed`` cluster, streaming the results
to a resumable Parquet dataset, and writes ``summary.json``;
``write_replay`` writes one run's whole scenario for ``agvnav simulate``.
Dask and pyarrow are the optional ``campaign`` extra: ``pip install agvnav[campaign]``.
"""

from agvnav.campaign.overrides import BaseScenario, apply_overrides, load_base, set_dotted
from agvnav.campaign.plan import RunPlan, plan_runs, run_seed
from agvnav.campaign.runner import CampaignResult, run_campaign, write_replay
from agvnav.campaign.spec import CampaignSpec, Distribution, load_campaign, parse_campaign
from agvnav.campaign.store import finished_runs, read_results
from agvnav.campaign.summary import describe, summarize
from agvnav.campaign.task import metric_names, run_batch, run_one, simulate_metrics

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
