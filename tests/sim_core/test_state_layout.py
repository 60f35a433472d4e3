"""The packed vectors the kernels read by index agree with the code that packs them.

* ``sim_core.kart.P_*`` index the kart vector that :meth:`KartParams.as_array` packs in the order of
  ``KART_PARAM_FIELDS``: each constant must be the index of its field (matched by name, see
  :func:`field_of`), and every field must have one.
* ``sim_core.state.RP_*`` index the rule vector that ``SimParams.rule_vector`` packs: each must be set there,
  once, and the indices must fill ``0 .. N_RULE - 1``.

A constant that drifts from its field would make the kernels read, say, the braking limit as the top speed,
with no error anywhere.
"""

from __future__ import annotations

import ast
import inspect
import textwrap

import numpy as np

import sim_core.kart as kart_module
import sim_core.state as state_module
from sim_core.params import KART_PARAM_FIELDS, KartParams, SimParams
from sim_core.track_io import get_track
from sim_core.world import World


def constants(module: object, prefix: str) -> dict[str, int]:
    """The module's integer constants whose names start with ``prefix``, by name."""
    return {
        name: value
        for name, value in vars(module).items()
        if name.startswith(prefix) and isinstance(value, int) and not isinstance(value, bool)
    }


def field_of(constant: str, fields: tuple[str, ...]) -> str:
    """The field a ``P_*`` constant names: the field of the same name, else the one field whose words contain
    the constant's words in order (``P_G_FRESH`` -> ``lateral_g_fresh``, ``P_WEAR_SCALE`` -> ``wear_yaw_scale``)."""
    words = constant.removeprefix("P_").lower().split("_")
    if "_".join(words) in fields:
        return "_".join(words)

    def contains_in_order(field: str) -> bool:
        remaining = iter(field.split("_"))
        return all(word in remaining for word in words)

    matches = [f for f in fields if contains_in_order(f)]
    assert len(matches) == 1, f"{constant} matches {matches or 'no field'} of KART_PARAM_FIELDS; rename it"
    return matches[0]


def test_every_kart_index_constant_is_the_index_of_its_field() -> None:
    p_constants = constants(kart_module, "P_")
    assert p_constants, "no P_* constants in sim_core.kart"
    named = {name: field_of(name, KART_PARAM_FIELDS) for name in p_constants}
    for name, field in named.items():
        assert p_constants[name] == KART_PARAM_FIELDS.index(field), (
            f"{name} = {p_constants[name]} but {field!r} is at {KART_PARAM_FIELDS.index(field)} in KART_PARAM_FIELDS"
        )
    assert sorted(named.values()) == sorted(KART_PARAM_FIELDS), (
        f"fields without a P_* constant: {sorted(set(KART_PARAM_FIELDS) - set(named.values()))}"
    )


def test_the_packed_kart_vector_holds_each_field_at_its_constant() -> None:
    # distinct values per field, so a swapped pair shows
    params = KartParams(**{f: float(i + 1) for i, f in enumerate(KART_PARAM_FIELDS)})
    vector = params.as_array()
    for name, index in constants(kart_module, "P_").items():
        assert vector[index] == getattr(params, field_of(name, KART_PARAM_FIELDS)), name


def assigned_rule_indices() -> list[str]:
    """Names of the ``RP_*`` constants that ``SimParams.rule_vector`` assigns to (``v[st.RP_X] = ...``)."""
    tree = ast.parse(textwrap.dedent(inspect.getsource(SimParams.rule_vector)))
    names: list[str] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Assign | ast.AugAssign | ast.AnnAssign):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for target in targets:
                if isinstance(target, ast.Subscript):
                    index = target.slice
                    if isinstance(index, ast.Attribute) and index.attr.startswith("RP_"):
                        names.append(index.attr)
                    elif isinstance(index, ast.Name) and index.id.startswith("RP_"):
                        names.append(index.id)
    return names


def test_every_rule_index_constant_is_set_once_by_the_world() -> None:
    rp_constants = constants(state_module, "RP_")
    assert rp_constants, "no RP_* constants in sim_core.state"
    assigned = assigned_rule_indices()
    assert sorted(assigned) == sorted(set(assigned)), f"set more than once: {sorted(assigned)}"
    assert set(assigned) == set(rp_constants), (
        f"never set by SimParams.rule_vector: {sorted(set(rp_constants) - set(assigned))}; "
        f"not in sim_core.state: {sorted(set(assigned) - set(rp_constants))}"
    )
    assert sorted(rp_constants.values()) == list(range(state_module.N_RULE)), "RP_* indices must fill 0..N_RULE-1"


def test_the_rule_vector_has_one_slot_per_constant() -> None:
    world = World(get_track("train-oval-small"), 1, 1, sensors=False)
    assert world.rule_vector.shape == (state_module.N_RULE,)
    assert np.all(np.isfinite(world.rule_vector))
