"""A plan as plain data (:meth:`controllers.plan.Plan.as_dict`): what ``dataclasses.asdict`` gives, for any plan."""

from __future__ import annotations

from dataclasses import asdict

from hypothesis import given
from hypothesis import strategies as st

from controllers.plan import Plan, Waypoint

numbers = st.floats(allow_nan=False, allow_infinity=False)
waypoints = st.builds(Waypoint, st.integers(0, 400), st.integers(1, 6), st.tuples(numbers, numbers), numbers, numbers)
plans = st.builds(
    Plan,
    st.integers(0, 7),
    st.integers(0, 400),
    st.dictionaries(st.integers(0, 7), st.lists(waypoints, max_size=9).map(tuple), max_size=8),
    st.integers(0, 5000),
    st.integers(0, 5000),
    numbers,
    st.integers(0, 8),
)


@given(plans)
def test_as_dict_is_asdict(plan: Plan) -> None:
    data = plan.as_dict()
    assert data == asdict(plan)
    assert repr(data) == repr(asdict(plan))  # the same containers (tuples stay tuples), the same order
