"""The study text the CLI tests write: the benchmark beam with a parametric joint at node 10, Model 3 layout."""


def beam_study_toml(joint_extra: str = "", start: float = 5.0, stop: float = 1000.0, step: float = 5.0, shear_coefficient: bool = True) -> str:
    """Study TOML; ``joint_extra`` holds extra ``[joint.model]`` lines (e.g. frequency growth)."""
    shear = "shear_coefficient = 0.8333333333333334\n" if shear_coefficient else ""
    return f"""
[beam]
length = 0.9144
width = 0.0127
height = 0.0127
elastic_modulus = 69e9
density = 2700.0
loss_factor = 0.006
poisson_ratio = 0.33
{shear}nodes = 19

[joint]
node = 10
dofs = ["w", "theta"]

[joint.model]
type = "parametric"
k_w_w = 2.0e5
k_w_theta = 1.5e3
k_theta_theta = 60.0
loss_factor = 0.12
{joint_extra}
[measurement]
observed = [1, 3, 6, 9, 12, 15, 19]
excited  = [3, 9, 15]

[frequency]
start = {start!r}
stop = {stop!r}
step = {step!r}
"""
