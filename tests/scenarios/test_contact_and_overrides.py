"""[[contact]] in scenario files and `--set KEY=VALUE` overrides: validation names the key."""

import copy

import numpy as np
import pytest
from test_schema import BASE

from tissuempm.scenarios.build import build
from tissuempm.scenarios.overrides import apply_overrides
from tissuempm.scenarios.schema import Scenario, ScenarioError, load_scenario


def two_bodies(**contact):
    data = copy.deepcopy(BASE)
    data["body"][0]["name"] = "tissue"
    data["body"].append(
        {"name": "probe", "material": "tissue",
         "shape": {"type": "box", "lower": ["2 mm", "2 mm", "8 mm"], "upper": ["8 mm", "8 mm", "9 mm"]}}
    )  # fmt: skip
    if contact:
        data["contact"] = [{"bodies": ["tissue", "probe"], **contact}]
    return data


def test_contact_pair_gives_each_body_its_own_field():
    prob = build(Scenario.from_dict(two_bodies(law="friction", mu=0.2)))
    law = prob.model.contact.laws[(0, 1)]
    assert (law.kind, law.mu, law.separation) == ("friction", 0.2, "gap")
    node = build(Scenario.from_dict(two_bodies(law="frictionless", separation="node")))
    assert node.model.contact.laws[(0, 1)].separation == "node"
    assert np.array_equal(prob.particles.field, prob.body)
    bonded = build(Scenario.from_dict(two_bodies()))
    assert bonded.model.contact is None and not bonded.particles.field.any()


@pytest.mark.parametrize(
    "contact, text",
    [
        ({"law": "frictionless", "mu": 0.3}, "mu = 0.3 is only valid with law = 'friction'"),
        ({"law": "glue"}, "contact[0].law"),
        ({"law": "friction", "mu": -1}, "contact[0].mu"),
        ({"law": "friction", "separation": "early"}, "contact[0].separation"),
    ],
)
def test_bad_contact_is_named(contact, text):
    with pytest.raises(ScenarioError, match=text.replace("[", r"\[").replace("]", r"\]")):
        Scenario.from_dict(two_bodies(**contact))


def test_contact_with_unknown_body_is_named():
    data = two_bodies(law="frictionless")
    data["contact"][0]["bodies"] = ["tissue", "bullet"]
    with pytest.raises(ScenarioError, match=r"contact\[0\]\.bodies: 'bullet' is not a body name"):
        Scenario.from_dict(data)


def three_bodies(*contacts):
    data = two_bodies()
    data["body"].append(
        {"name": "cap", "material": "tissue",
         "shape": {"type": "box", "lower": ["2 mm", "2 mm", "9 mm"], "upper": ["8 mm", "8 mm", "10 mm"]}}
    )  # fmt: skip
    data["contact"] = list(contacts)
    return data


def test_contact_between_groups_acts_between_every_pair_across_them():
    """``bodies = [A, [B, C]]`` is the law between A and B and between A and C (B and C bonded: one field)."""
    prob = build(Scenario.from_dict(three_bodies({"bodies": ["tissue", ["probe", "cap"]], "law": "sliding"})))
    assert prob.model.contact.n_fields == 2 and prob.model.contact.laws[(0, 1)].kind == "sliding"
    field = dict(zip(("tissue", "probe", "cap"), (int(prob.particles.field[prob.body == i][0]) for i in range(3))))
    assert field["probe"] == field["cap"] != field["tissue"]


@pytest.mark.parametrize(
    "contacts, text",
    [
        ([{"bodies": ["tissue", ["probe", "tissue"]], "law": "sliding"}], r"\['tissue'\] on both sides"),
        ([{"bodies": [["tissue", "cap"], "probe"], "law": "sliding"},
          {"bodies": ["probe", "cap"], "law": "frictionless"}], r"contact\[1\]\.bodies: a second law for the pair"),
        ([{"bodies": ["tissue", ["probe", "lid"]], "law": "sliding"}], r"contact\[0\]\.bodies: 'lid' is not a body"),
    ],
)  # fmt: skip
def test_bad_contact_groups_are_named(contacts, text):
    with pytest.raises(ScenarioError, match=text):
        Scenario.from_dict(three_bodies(*contacts))


def test_overrides_set_nested_keys_with_units():
    data = apply_overrides(
        copy.deepcopy(BASE),
        ["solver.cfl=0.1", 'body[0].velocity=[0, "150 m/s", 0]', "grid.cell_size=0.5 mm", "run.max_steps=7"],
    )
    sc = Scenario.from_dict(data)
    assert sc.solver.cfl == 0.1 and sc.bodies[0].velocity[1] == 150.0
    assert sc.grid.cell_size == pytest.approx(0.5e-3) and sc.run.max_steps == 7


@pytest.mark.parametrize(
    "item, text",
    [
        ("solver.cfl", "expected KEY=VALUE"),
        ("body[3].velocity=[0, 0, 0]", "index 3 is out of range"),
        ("solver.cfl.x=1", "is not inside a table"),
        ("so lver=1", "is not a key"),
    ],
)
def test_bad_overrides_are_named(item, text):
    with pytest.raises(ScenarioError, match=text):
        apply_overrides(copy.deepcopy(BASE), [item])


def test_override_values_are_validated_like_the_file(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(
        '[grid]\nlower = [0, 0, 0]\nupper = [1, 1, 1]\ncell_size = 0.25\n'
        '[materials.m]\nkind = "neo_hookean"\n'
        '[[body]]\nmaterial = "m"\nshape = { type = "box", lower = [0, 0, 0], upper = [1, 1, 1] }\n'
        '[run]\nend_time = 1.0\n'
    )
    assert load_scenario(path, ["solver.cfl=0.5"]).solver.cfl == 0.5
    with pytest.raises(ScenarioError, match="solver.cfl"):
        load_scenario(path, ["solver.cfl=2"])


def test_an_override_reaches_the_inner_law_of_a_library_failure_layer():
    """``--set 'materials.gel.base.yield_stress="2.2 MPa"'`` on a library failure layer (the ballistic
    gelatin card: erosion at eqps 0.9 around an elastic-plastic base) changes the base's yield stress only,
    in the file's units; the criterion, the limit and the base's other parameters stay the library's;
    a bad inner value is named with its range; a table with ``kind`` replaces the inner law (and is checked
    against the layer's criterion)."""
    from tissuempm import library

    data = copy.deepcopy(BASE)
    data["materials"] = {"gel": {"library": "ballistic_gelatin"}}
    data["body"][0]["material"] = "gel"
    card = library.get("ballistic_gelatin").material
    gel = Scenario.from_dict(apply_overrides(data, ['materials.gel.base.yield_stress="2.2 MPa"'])).build_materials()[0]
    assert gel.base.yield_stress == pytest.approx(2.2e6) and card.base.yield_stress == pytest.approx(0.22e6)
    assert gel.replace(base=card.base) == card
    with pytest.raises(ScenarioError, match=r"materials.gel: ElasticPlastic.yield_stress = -2000000.0 is out of range"):
        Scenario.from_dict(apply_overrides(data, ['materials.gel.base.yield_stress="-2 MPa"']))
    swapped = apply_overrides(data, ['materials.gel.base={kind="neo_hookean", C10="1 kPa", K="1 MPa"}'])
    with pytest.raises(ScenarioError, match="base NeoHookean has no equivalent plastic strain"):
        Scenario.from_dict(swapped)  # replaced, and checked against the layer's criterion
