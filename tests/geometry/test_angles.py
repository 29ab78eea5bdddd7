"""The one wrap convention, [-pi, pi): range, exactness, ±pi, large multiples, scalar == array bits."""

import math
import re
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import agvnav
from agvnav.geometry import PI, TWO_PI, angle_diff, wrap_angle, wrap_angle_scalar

finite = st.floats(allow_nan=False, allow_infinity=False)
moderate = st.floats(-1e6, 1e6)
inside = st.floats(-math.pi, math.pi, exclude_max=True)


def bits(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64).view(np.int64)


def is_multiple_of_two_pi(delta: Fraction) -> bool:
    q = delta / Fraction(TWO_PI)
    return q.denominator == 1


@given(finite)
def test_result_in_half_open_interval_and_exact_multiple_of_two_pi(a):
    w = wrap_angle_scalar(a)
    assert -math.pi <= w < math.pi
    assert is_multiple_of_two_pi(Fraction(a) - Fraction(w))  # a - k * TWO_PI with no rounding at all


@given(inside)
def test_identity_inside_the_interval(a):
    assert wrap_angle_scalar(a) == a
    assert float(wrap_angle(a)) == a
    assert math.copysign(1.0, wrap_angle_scalar(a)) == math.copysign(1.0, a)  # -0.0 stays -0.0


@pytest.mark.parametrize("k", [-(2**40), -1001, -3, -1, 0, 1, 2, 7, 1000, 2**40])
def test_exact_plus_minus_pi_and_odd_multiples_map_to_minus_pi(k):
    assert wrap_angle_scalar(PI) == -PI
    assert wrap_angle_scalar(-PI) == -PI
    a = Fraction(PI) + k * Fraction(TWO_PI)  # exactly representable for these k (power-of-two scaling or small k)
    if float(a) == a:
        assert wrap_angle_scalar(float(a)) == -PI
        assert float(wrap_angle(float(a))) == -PI


@given(st.integers(-(10**6), 10**6), inside)
def test_large_multiples_come_back_to_the_angle(k, a):
    w = wrap_angle_scalar(a + k * TWO_PI)
    # a + k*TWO_PI rounds (by at most half an ulp of its magnitude); the wrap itself adds nothing
    tol = 2.0 * math.ulp(abs(a) + abs(k) * TWO_PI)
    assert abs(math.remainder(w - a, TWO_PI)) <= tol


@given(arrays(np.float64, st.integers(0, 40), elements=st.floats(allow_nan=True, allow_infinity=False)))
def test_scalar_and_array_forms_agree_to_the_last_bit(a):
    expected = np.array([wrap_angle_scalar(float(v)) for v in a], dtype=np.float64)
    np.testing.assert_array_equal(bits(wrap_angle(a)), bits(expected))


def test_scalar_and_array_forms_agree_on_many_values():
    rng = np.random.default_rng(20261123)
    a = np.concatenate([
        rng.uniform(-10.0, 10.0, 50_000),
        rng.normal(0.0, 1e-9, 10_000),
        rng.uniform(-1e12, 1e12, 10_000),
        np.array([PI, -PI, TWO_PI, -TWO_PI, 3 * PI, -3 * PI, 0.0, -0.0, np.nextafter(PI, 0), np.nextafter(-PI, -4),
                  5e-324, -5e-324, 1e308, -1e308]),
        np.nextafter(PI + TWO_PI * np.arange(-50, 50), np.inf),
        PI + TWO_PI * np.arange(-50, 50),
    ])
    w = wrap_angle(a)
    assert w.shape == a.shape and w.dtype == np.float64
    assert np.all((w >= -PI) & (w < PI))
    np.testing.assert_array_equal(bits(w), bits(np.array([wrap_angle_scalar(float(v)) for v in a])))


def test_shapes_and_scalar_type():
    assert isinstance(wrap_angle(7.0), np.float64)
    assert wrap_angle(np.zeros((2, 0))).shape == (2, 0)
    assert wrap_angle(np.full((3, 2), 3 * PI)).shape == (3, 2)
    a = np.array([4.0, -4.0])
    wrap_angle(a)
    np.testing.assert_array_equal(a, [4.0, -4.0])  # the input is not modified


def test_nan_and_infinity_give_nan():
    assert math.isnan(wrap_angle_scalar(math.nan))
    assert math.isnan(wrap_angle_scalar(math.inf)) and math.isnan(wrap_angle_scalar(-math.inf))
    assert math.isnan(float(wrap_angle(math.inf)))
    assert np.isnan(wrap_angle(np.array([np.nan, 1.0]))[0])


@given(moderate, moderate)
def test_angle_diff_is_the_wrapped_difference(a, b):
    d = float(angle_diff(a, b))
    assert d == wrap_angle_scalar(a - b)
    assert -math.pi <= d < math.pi


def test_angle_diff_half_turn_is_minus_pi_both_ways():
    assert float(angle_diff(PI, 0.0)) == -PI
    assert float(angle_diff(0.0, PI)) == -PI
    assert math.isclose(float(angle_diff(PI - 0.1, -PI + 0.1)), -0.2, abs_tol=1e-15)


#: Ways of wrapping an angle that do not go through agvnav.geometry (each has its own ±pi convention).
OTHER_WRAPS = re.compile(
    r"\bremainder\("  # math.remainder / np.remainder: [-pi, pi] with ties to even
    r"|(%|\bmod\()[^\n#]*-\s*(np\.|math\.|_)?(pi|PI)\b"  # (a + pi) % 2pi - pi: rounds inside the interval
    r"|\b(rint|round)\([^)\n]*/\s*\(?(_?TWO_PI|2(\.0)?\s*\*\s*(np|math)\.pi)"  # a - 2pi rint(a / 2pi)
    r"|\b(atan2|arctan2)\((math|np)\.sin\("  # atan2(sin a, cos a): (-pi, pi]
    r"|\bangle\(np\.exp\(1j"
)


def test_the_library_wraps_angles_only_through_geometry():
    src = Path(agvnav.__file__).parent
    hits = [
        f"{path.relative_to(src)}:{n}: {line.strip()}"
        for path in sorted(src.rglob("*.py"))
        if path.name != "angles.py" or path.parent.name != "geometry"
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
        if OTHER_WRAPS.search(line.split("#")[0])
    ]
    assert not hits, "wrap angles with agvnav.geometry.wrap_angle[_scalar]:\n" + "\n".join(hits)


@pytest.mark.parametrize("line", [
    "h = (a + math.pi) % (2.0 * math.pi) - math.pi",
    "r = math.remainder(x, 2 * math.pi)",
    "w = a - TWO_PI * xp.rint(a / TWO_PI)",
    "r -= TWO_PI * round(r / TWO_PI)",
    "g = np.arctan2(np.sin(a), np.cos(a))",
    "innov = (z - h + _PI) % _TWO_PI - _PI",
    "f = np.mod(raw + math.pi, TWO_PI) - math.pi",
])
def test_the_guard_recognises_the_usual_wraps(line):
    assert OTHER_WRAPS.search(line)
