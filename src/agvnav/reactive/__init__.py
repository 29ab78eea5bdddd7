"""Reactive control (issue 18; the outline's [seed003 §3.7]): safety fields switched by speed, the
slow/stop/resume reaction, local avoidance.

:mod:`~agvnav.reactive.fields` generates and selects protective/warning fields from the
stopping distance and a person's approach (ISO 13855 S = K T + C);
:mod:`~agvnav.reactive.reaction` is the state machine that turns
field intrusions into a speed scale; :mod:`~agvnav.reactive.avoidance` plans a
lateral-offset detour inside a corridor. Pure and stateful parts only: the wiring
into the closed loop is :mod:`agvnav.sim.reactive`.
"""

from __future__ import annotations

from agvnav.reactive.avoidance import Detour, path_tail, plan_detour, scanned_obstacle, shift_arcs
from agvnav.reactive.fields import (
    ISO13855_K_M_S,
    FieldConfig,
    FieldSet,
    approach_clearance,
    approach_field,
    approach_reach,
    field_rectangle,
    generate_fields,
    intrusions,
    stopping_distance,
    swept_strip,
)
from agvnav.reactive.reaction import REACTION_STATES, Reaction, ReactionLimits, field_demand

__all__ = [
    "ISO13855_K_M_S",
    "REACTION_STATES",
    "Detour",
    "FieldConfig",
    "FieldSet",
    "Reaction",
    "ReactionLimits",
    "approach_clearance",
    "approach_field",
    "approach_reach",
    "field_demand",
    "field_rectangle",
    "generate_fields",
    "intrusions",
    "path_tail",
    "plan_detour",
    "scanned_obstacle",
    "shift_arcs",
    "stopping_distance",
    "swept_strip",
]
