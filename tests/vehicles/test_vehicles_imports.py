"""The truth vehicles never import the simulator (docs/ARCHITECTURE.md: sim wires, vehicles are parts)."""

from __future__ import annotations

import subprocess
import sys


def test_importing_vehicles_loads_no_sim_module() -> None:
    code = "import sys, agvnav.vehicles; print(sorted(m for m in sys.modules if m.startswith('agvnav.sim')))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"
