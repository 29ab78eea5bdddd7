"""``agvnav bench`` without an optional extra: one line naming it, exit 2; ``bench mapping`` needs none (issue 29)."""

from __future__ import annotations

import subprocess
import sys

import pytest
from typer.testing import CliRunner

from agvnav.cli import app

runner = CliRunner()

#: What the campaign extra installs: None in sys.modules makes their import fail as if absent.
CAMPAIGN_EXTRA = ("dask", "distributed", "pyarrow")


def _without_campaign_extra(monkeypatch: pytest.MonkeyPatch, *reimport: str) -> None:
    for name in CAMPAIGN_EXTRA:
        monkeypatch.setitem(sys.modules, name, None)
    for name in reimport:  # imported by an earlier test: imported again, now without the extra
        monkeypatch.delitem(sys.modules, name, raising=False)


def test_bench_speed_without_dask_is_one_line_naming_the_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    """Before: a ModuleNotFoundError traceback. The campaign rows are part of the benchmark: it stops, exit 2."""
    _without_campaign_extra(monkeypatch, "agvnav.bench.speed", "agvnav.campaign.runner", "agvnav.campaign.store",
                            "agvnav.campaign.summary")
    res = runner.invoke(app, ["bench", "speed", "--quick"])
    assert res.exit_code == 2, res.output
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and "pip install 'agvnav[campaign]'" in lines[0] and "bench speed" in lines[0]
    assert res.exception is None or isinstance(res.exception, SystemExit)


def test_campaign_without_dask_is_one_line_naming_the_extra(monkeypatch: pytest.MonkeyPatch, tmp_path) -> None:
    _without_campaign_extra(monkeypatch, "agvnav.campaign.runner", "agvnav.campaign.store", "agvnav.campaign.summary")
    res = runner.invoke(app, ["campaign", "default_seeds", "--out", str(tmp_path / "o")])
    assert res.exit_code == 2 and "pip install 'agvnav[campaign]'" in res.output
    assert len(res.output.strip().splitlines()) == 1 and not (tmp_path / "o").exists()


def test_bench_mapping_imports_without_dask() -> None:
    """Before: `bench mapping` failed importing agvnav.campaign (its runner needs Dask) for the scenario overrides
    it uses, which need no extra. A fresh interpreter without the extra imports the benchmark and those names."""
    block = "; ".join(f"sys.modules[{m!r}] = None" for m in CAMPAIGN_EXTRA)
    code = (f"import sys; {block}; import agvnav.bench.mapping, agvnav.campaign as c; c.load_campaign('default_seeds')"
            "\ntry:\n    c.run_campaign\nexcept ModuleNotFoundError as e:\n    print('needs', e.name)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["needs", "dask"]  # the runner's names still need the extra, on first use
