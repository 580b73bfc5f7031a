"""One material type: the elastomer, the beam and the reproduce configuration share :class:`Material`."""

from __future__ import annotations

import pytest

from jointid.errors import ModelError, StudyError
from jointid.physics.elastomer_joint import ElastomerJoint
from jointid.physics.elastomer_material import MATERIALS, ElastomerMaterial
from jointid.physics.elements import Material
from jointid.reproduce.config import load_config


def test_elastomer_material_is_a_material_with_its_short_names():
    b = MATERIALS["B"]
    assert isinstance(b, Material)
    assert (b.E, b.eta, b.rho, b.nu) == (8.8e6, 0.15, 1100.0, 0.49)
    assert b.G == pytest.approx(8.8e6 / 2.98, rel=1e-15)
    assert b.complex_modulus == complex(8.8e6, 8.8e6 * 0.15)
    assert ElastomerJoint.from_material("B", cap=None).material == b


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"elastic_modulus": -1.0, "density": 1100.0}, "elastomer elastic modulus must be a positive finite number in Pa, got -1.0"),
        ({"elastic_modulus": 1e6, "density": 1100.0, "loss_factor": -0.1}, "elastomer loss factor must be >= 0, got -0.1"),
        ({"elastic_modulus": 1e6, "density": 1100.0, "poisson_ratio": 0.5}, r"elastomer Poisson ratio must lie in \(-1, 0.5\), got 0.5"),
        ({"elastic_modulus": 1e6, "density": 1100.0, "shear_modulus": 3e5}, "elastomer material: give poisson_ratio"),
    ],
)
def test_elastomer_material_checks_name_the_elastomer(kwargs, message):
    with pytest.raises(ModelError, match=f"^{message}"):
        ElastomerMaterial(**kwargs)


def test_joint_checks_its_material_through_elastomer_material():
    with pytest.raises(ModelError, match="^elastomer density must be a positive finite number in kg/m\\^3, got 0.0$"):
        ElastomerJoint(1e7, 0.1, 0.0)


def test_reproduce_config_materials_are_elastomer_materials(tmp_path):
    assert dict(load_config().materials) == dict(MATERIALS)
    p = tmp_path / "c.toml"
    p.write_text("[materials.A]\nloss_factor = 0.2\n[materials.C]\nelastic_modulus = 5e6\nloss_factor = 0.05\ndensity = 1000.0\n")
    mats = load_config(p).materials
    assert mats["A"] == ElastomerMaterial(15e6, 1200.0, 0.2)
    assert mats["C"] == ElastomerMaterial(5e6, 1000.0, 0.05) and mats["C"].nu == 0.49
    p.write_text("[materials.C]\nelastic_modulus = 5e6\nloss_factor = -0.05\ndensity = 1000.0\n")
    with pytest.raises(StudyError, match=r"\[materials.C\].loss_factor: expected a non-negative number, got -0.05$"):
        load_config(p)


def test_joint_from_any_material_with_a_poisson_ratio():
    steel_like = Material(8.8e6, 1100.0, 0.15, poisson_ratio=0.49)
    assert ElastomerJoint.from_material(steel_like, cap=None).material == MATERIALS["B"]
    with pytest.raises(ModelError, match="^elastomer material: give poisson_ratio"):
        ElastomerJoint.from_material(Material(8.8e6, 1100.0, 0.15, shear_modulus=3e6))
