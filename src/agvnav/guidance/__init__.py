"""guidance: paths, the seed-000 guidance laws (seed 000 §3) and baseline controllers.

* :mod:`.paths` - line/arc paths, projection, YAML in/out;
* :mod:`.errors` - errors of Fig. 5 ([seed000 eq9] [seed000 eq10]) and the curvature feed-forward;
* :mod:`.laws` - general law ([seed000 eq11] [seed000 eq12] [seed000 eq13]) and simple law
  ([seed000 eq20] [seed000 eq21] [seed000 eq22]) kernels;
* :mod:`.gains` - poles per metre -> a, b, c; Routh-Hurwitz ([seed000 eq17] [seed000 eq18] [seed000 eq19]);
* :mod:`.baselines` - pure pursuit, Stanley, steering servo;
* :mod:`.controller` - stateful controllers and ``make_controller``;
* :mod:`.follower` - the path-follower role (``PathFollower``), its failures
  (``GuidanceError``, ``InfeasiblePathError``) and errors (``FollowErrors``);
* :mod:`.steered`, :mod:`.unicycle`, :mod:`.holonomic` - followers per family;
* :mod:`.followers` - ``FOLLOWERS``, ``make_follower``, ``check_path_feasible``;
* :mod:`.approach` - ``HeadingHoldApproach``, a steered station approach holding the heading;
* :mod:`.fine_positioning` - ``FinePositioner``, ``move_profile``: a spot-turning vehicle's
  corrections at standstill after a station stop.
"""

from agvnav.guidance.approach import HeadingHoldApproach
from agvnav.guidance.baselines import (
    MAX_STEERING_RAD,
    lookahead_for_distance,
    pure_pursuit_steering,
    servo_rate,
    stanley_gain_for_distance,
    stanley_steering,
)
from agvnav.guidance.controller import (
    CONTROLLERS,
    DEFAULT_CONVERGENCE_DISTANCE_M,
    GuidanceController,
    PurePursuitController,
    SeedGeneralController,
    SeedSimpleController,
    StanleyController,
    linearised_loop,
    linearised_poles_per_metre,
    loop_convergence_distance,
    make_controller,
    tune_for_convergence,
)
from agvnav.guidance.errors import (
    POINTS,
    TrackingErrors,
    errors_from_projection,
    feedforward_steering,
    point_c,
    tracking_errors,
    tracking_errors_scalar,
)
from agvnav.guidance.fine_positioning import FinePositioner, move_profile
from agvnav.guidance.follower import (
    FAMILIES,
    FollowErrors,
    GuidanceError,
    InfeasiblePathError,
    PathFollower,
)
from agvnav.guidance.followers import (
    FOLLOWERS,
    GEOMETRY_FIELDS,
    FollowerParameter,
    check_path_feasible,
    follower_parameters,
    make_follower,
    min_turning_radius,
)
from agvnav.guidance.gains import (
    SETTLING_FRACTION,
    GeneralGains,
    SimpleGains,
    arc_linear_model,
    characteristic_coefficients,
    check_routh_hurwitz,
    check_simple_stability,
    convergence_distance,
    envelope_distance,
    general_characteristic,
    general_gains,
    general_gains_from_coefficients,
    general_gains_on_arc,
    modal_response,
    poles_for_convergence,
    routh_hurwitz_ok,
    seed_loop_matrix,
    seed_poles_for_distance,
    simple_characteristic,
    simple_gains,
)
from agvnav.guidance.holonomic import HolonomicFollower, holonomic_body_twist
from agvnav.guidance.kanayama import CRITICAL_SETTLING_PER_DISTANCE, KanayamaGains, kanayama_path_rate
from agvnav.guidance.laws import GENERAL_FORMS, SIMPLE_FORMS, general_law, simple_law
from agvnav.guidance.paths import (
    GAP_TOLERANCE_M,
    ArcSegment,
    LineSegment,
    Path,
    PathProjection,
    PointProjection,
    Segment,
    load_path,
    path_from_moves,
    save_path,
    seed_test_path,
)
from agvnav.guidance.steered import SteeredFollower, drive_speed
from agvnav.guidance.unicycle import (
    KanayamaPathFollower,
    UnicyclePurePursuit,
    UnicycleStanley,
    pure_pursuit_lookahead_for_distance,
)

__all__ = [
    "CONTROLLERS",
    "CRITICAL_SETTLING_PER_DISTANCE",
    "DEFAULT_CONVERGENCE_DISTANCE_M",
    "FAMILIES",
    "FOLLOWERS",
    "GAP_TOLERANCE_M",
    "GENERAL_FORMS",
    "GEOMETRY_FIELDS",
    "MAX_STEERING_RAD",
    "POINTS",
    "SETTLING_FRACTION",
    "SIMPLE_FORMS",
    "ArcSegment",
    "FinePositioner",
    "FollowErrors",
    "FollowerParameter",
    "GeneralGains",
    "GuidanceController",
    "GuidanceError",
    "HeadingHoldApproach",
    "HolonomicFollower",
    "InfeasiblePathError",
    "KanayamaGains",
    "KanayamaPathFollower",
    "LineSegment",
    "Path",
    "PathFollower",
    "PathProjection",
    "PointProjection",
    "PurePursuitController",
    "SeedGeneralController",
    "SeedSimpleController",
    "Segment",
    "SimpleGains",
    "StanleyController",
    "SteeredFollower",
    "TrackingErrors",
    "UnicyclePurePursuit",
    "UnicycleStanley",
    "arc_linear_model",
    "characteristic_coefficients",
    "check_path_feasible",
    "check_routh_hurwitz",
    "check_simple_stability",
    "convergence_distance",
    "drive_speed",
    "envelope_distance",
    "errors_from_projection",
    "feedforward_steering",
    "follower_parameters",
    "general_characteristic",
    "general_gains",
    "general_gains_from_coefficients",
    "general_gains_on_arc",
    "general_law",
    "holonomic_body_twist",
    "kanayama_path_rate",
    "linearised_loop",
    "linearised_poles_per_metre",
    "load_path",
    "lookahead_for_distance",
    "loop_convergence_distance",
    "make_controller",
    "make_follower",
    "min_turning_radius",
    "modal_response",
    "move_profile",
    "path_from_moves",
    "point_c",
    "poles_for_convergence",
    "pure_pursuit_lookahead_for_distance",
    "pure_pursuit_steering",
    "routh_hurwitz_ok",
    "save_path",
    "seed_loop_matrix",
    "seed_poles_for_distance",
    "seed_test_path",
    "servo_rate",
    "simple_characteristic",
    "simple_gains",
    "simple_law",
    "stanley_gain_for_distance",
    "stanley_steering",
    "tracking_errors",
    "tracking_errors_scalar",
    "tune_for_convergence",
]
