"""Write a simulated run in the CSV log layout (docs/logs.md): the tests' small logs, made by the tests."""

import json
from pathlib import Path

import numpy as np

from agvnav.logs import positioning_settings


def write_csv_log(result, folder: Path, settings: dict | None = None) -> Path:
    """``result`` as odometry.csv, reflections.csv, truth.csv and settings.json (``settings`` replaces the run's)."""
    s, refl = result.series, result.events["reflections"]
    folder.mkdir(parents=True, exist_ok=True)
    kw = {"delimiter": ",", "comments": "", "fmt": "%.17g"}
    np.savetxt(folder / "odometry.csv", np.column_stack([s["t"], s["odo_dd"], s["odo_dtheta"]]),
               header="t,delta_d,delta_theta", **kw)
    np.savetxt(folder / "reflections.csv", np.column_stack([refl["t"], refl["bearing"]]), header="t,bearing", **kw)
    np.savetxt(folder / "truth.csv", np.column_stack([s["t"], s["x"], s["y"], s["psi"]]), header="t,x,y,psi", **kw)
    doc = positioning_settings(result.scenario, s) if settings is None else settings
    (folder / "settings.json").write_text(json.dumps(doc, indent=2), encoding="utf-8")
    return folder
