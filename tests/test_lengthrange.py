"""Muscles on models with elements: the ``actuator_lengthrange`` that MuJoCo's compiler computes by simulation.

MuJoCo 4.0's compiler (``mjCModel::LengthRange`` calling ``mj_setLengthRange``) simulates the model it compiles
on a data made by ``mj_makeRawData``: a data without plugin instances (``d->nplugin == 0``), stepped with the
model, which has them. It disables spring and damper forces there (with contacts, gravity, friction loss and
actuation), so ``mj_passive`` returns before any plugin's ``compute``: elements exert no force in that
simulation, as MuJoCo's own joint springs do not, and only the plugin's ``advance`` runs, at every step. The
plugin once took that data for one made from another model (a false warning, and the elements read again at
every step of the simulation); it now leaves it alone. With passive forces on (``mj_setLengthRange`` on a data
of the model), the elements act in a length-range simulation as the joint springs that stand in for them.

The models (``tests.native_cases.arm_xml``): a planar arm whose elements sit in parallel with its hinges, stiff
about the hinge axis only, where MuJoCo's hinge springs of the same stiffness give the same forces.
"""

import os
import subprocess

import mujoco
import numpy as np
import pytest

from tests.conftest import c_compiler
from tests.native_cases import arm_xml, run_python

# Says the machine has 16 processors (sysconf, which libmujoco's std::thread::hardware_concurrency calls), so
# that MuJoCo's compiler runs its length-range simulations in threads, as on any machine of 4 or more (it takes
# half of them, and 1 on this project's 2-core test machine): thread 0 on its data without instances, the others
# on datas made by mj_makeData, which have them (a debug build showed the inits and advances on both).
SIXTEEN_PROCESSORS = r"""
#define _GNU_SOURCE
#include <dlfcn.h>
#include <unistd.h>
long sysconf(int name) {
  static long (*next)(int);
  if (!next) next = (long (*)(int))dlsym(RTLD_NEXT, "sysconf");
  return name == _SC_NPROCESSORS_ONLN || name == _SC_NPROCESSORS_CONF ? 16 : next(name);
}
"""


def test_the_compiler_computes_lengthranges_silently_and_leaves_nothing_behind():
    """In a fresh process (the warning was said once per process): compiled with warnings as errors, the arm with
    elements gets the lengthranges of the arm with hinge springs (and without: MuJoCo's simulation has no springs),
    its elements are never read for the compiler's data, and the registry holds nothing afterwards. A data made
    from the arm without elements and stepped with the one with them is still warned about, once, and gets the
    elements' forces (the springs'); drawing it reads nothing."""
    result = run_python("""
import ctypes, gc, warnings
import numpy as np
import mujoco
import mjflex_plugin
from tests.native_cases import arm_xml
lib = mjflex_plugin.library()
for f in (lib.mjfx_live_instances, lib.mjfx_states_count, lib.mjfx_stateless_reads):
    f.restype = ctypes.c_long
def registry():
    return lib.mjfx_live_instances(), lib.mjfx_states_count()
base = registry()
with warnings.catch_warnings():
    warnings.simplefilter("error")  # the spec plays MuJoCo's compile warnings back as Python warnings
    arms = {kind: mujoco.MjSpec.from_string(arm_xml(kind)).compile() for kind in ("element", "spring", "plain")}
arms["xml"] = mujoco.MjModel.from_xml_string(arm_xml("element"))  # prints its warnings: the parent reads the output
assert arms["element"].nplugin == arms["xml"].nplugin == 2 and arms["element"].nu == 2
assert lib.mjfx_stateless_reads() == 0, "the compiler's data had its elements read"
assert registry() == base, (registry(), base)
assert np.all(arms["element"].actuator_lengthrange[:, 1] > arms["element"].actuator_lengthrange[:, 0] + 0.01)
for kind in ("spring", "plain", "xml"):  # the same simulation (no forces from either): equal but for rounding
    np.testing.assert_allclose(arms["element"].actuator_lengthrange, arms[kind].actuator_lengthrange, rtol=1e-12)

element, spring = arms["element"], arms["spring"]
d = mujoco.MjData(arms["plain"])  # made from the arm without elements, stepped with the one with them
ref = mujoco.MjData(spring)
d.qpos[:] = ref.qpos[:] = [0.4, -0.7]
mujoco.mj_forward(element, d)
mujoco.mj_forward(spring, ref)
assert lib.mjfx_stateless_reads() == 1
np.testing.assert_allclose(d.qfrc_passive, ref.qfrc_passive, rtol=1e-12)
assert np.abs(ref.qfrc_passive).min() > 0.1
mujoco.mj_step(element, d)
reads = lib.mjfx_stateless_reads()
assert reads == 2, reads  # its one evaluation in the step; not its end (advance)
scene = mujoco.MjvScene(element, maxgeom=100)
mujoco.mjv_updateScene(element, d, mujoco.MjvOption(), None, mujoco.MjvCamera(), mujoco.mjtCatBit.mjCAT_ALL, scene)
assert lib.mjfx_stateless_reads() == reads  # nothing to draw without a state: nothing read
del d, ref
gc.collect()
assert registry() == base, (registry(), base)
print("done")
""")
    out = result.stdout + result.stderr
    assert out.count("mjflex:") == 1, out  # the one warning about the data made from the arm without elements
    assert "a data made from a model without mjflex.flexure instances is stepped with model 'arm_element'" in out


# the child of the test below: the arm compiled with warnings as errors, the registry empty afterwards
THREADED_COMPILE = """
import ctypes, os, warnings
import numpy as np
import mujoco
import mjflex_plugin
from tests.native_cases import arm_xml
assert os.cpu_count() == 16
lib = mjflex_plugin.library()
for f in (lib.mjfx_live_instances, lib.mjfx_states_count, lib.mjfx_stateless_reads):
    f.restype = ctypes.c_long
base = (lib.mjfx_live_instances(), lib.mjfx_states_count())
with warnings.catch_warnings():
    warnings.simplefilter("error")
    element = mujoco.MjSpec.from_string(arm_xml("element")).compile()
spring = mujoco.MjModel.from_xml_string(arm_xml("spring"))
assert (lib.mjfx_live_instances(), lib.mjfx_states_count()) == base and lib.mjfx_stateless_reads() == 0
np.testing.assert_allclose(element.actuator_lengthrange, spring.actuator_lengthrange, rtol=1e-12)
print("done")
"""


def test_the_compilers_length_range_threads_leave_nothing_behind(tmp_path):
    """MuJoCo's compiler on a machine of 16 processors: the arm's two muscles simulated in two threads, one on
    the data without instances, one on a data with them; silent, the registry empty afterwards, the lengthranges
    those of the arm with hinge springs."""
    shim = tmp_path / "libsixteen.so"
    (tmp_path / "sixteen.c").write_text(SIXTEEN_PROCESSORS)
    subprocess.run([c_compiler(), "-shared", "-fPIC", "-o", str(shim), str(tmp_path / "sixteen.c"), "-ldl"], check=True)
    preload = " ".join(p for p in (os.environ.get("LD_PRELOAD", ""), str(shim)) if p)  # after a sanitizer's runtime
    result = run_python(THREADED_COMPILE, env={"LD_PRELOAD": preload})
    assert "done" in result.stdout and "mjflex:" not in result.stdout + result.stderr


def _own_lengthranges(kind):
    """The arm's ``actuator_lengthrange``, shape (2, 2) [m], computed again by ``mj_setLengthRange`` with the
    compiler's options on a data of the model, its passive forces on."""
    spec = mujoco.MjSpec.from_string(arm_xml(kind))
    model = spec.compile()
    opt = mujoco.MjLROpt()
    for name in ("mode", "uselimit", "accel", "maxforce", "timeconst", "timestep", "inttotal", "interval", "tolrange"):
        setattr(opt, name, getattr(spec.compiler.LRopt, name))
    opt.useexisting = 0  # the compiled ranges are there: compute them again
    data = mujoco.MjData(model)
    for i in range(model.nu):
        mujoco.mj_setLengthRange(model, data, i, opt)
    return model.actuator_lengthrange.copy()


def test_with_passive_forces_on_the_elements_act_in_a_lengthrange_simulation_as_the_springs_do():
    """mj_setLengthRange on a data of the model (spring and damper forces on): the arm with elements gets the
    lengthranges of the arm with hinge springs, which differ from the arm's without either (the springs keep
    the shoulder muscle from its shortest length). Tolerance: the same forces but for rounding (the twist of a
    rotation about the frame's z axis is that angle), through 2 x 10 s of a damped simulation."""
    element, spring, plain = (_own_lengthranges(kind) for kind in ("element", "spring", "plain"))
    np.testing.assert_allclose(element, spring, rtol=1e-9)
    assert np.abs(element - plain).max() > 0.05 * np.ptp(plain[0]), (element, plain)


def test_a_muscle_across_a_replaced_joint_keeps_the_rigid_models_length_range():
    """With the elbow replaced by an element, the compiler's length-range simulation has nothing to hold the forearm
    (elements exert no force there, above) and does not converge; make_compliant writes the rigid model's ranges
    into the spec (Compliance.lengthranges), and make_rigid leaves them to the compiler again."""
    import mjflex

    spec = mujoco.MjSpec.from_string(arm_xml("plain"))
    rigid = spec.compile()
    bare = mujoco.MjSpec.from_string(arm_xml("plain"))
    bare.compiler.LRopt.useexisting = False  # the compiler computes every range again: 1.0.0's failure, explained
    with pytest.raises(ValueError, match=r"did not converge(.|\n)*give the actuator its lengthrange"):
        mjflex.make_compliant(bare, "lower", np.diag([2, 2, 0.2, 500, 500, 500]), replace_joints=True)
    assert not bare.plugins and bare.compile().nq == 2  # and left as it was
    compliance = mjflex.make_compliant(spec, "lower", np.diag([2, 2, 0.2, 500, 500, 500]), replace_joints=True)
    assert [(i, n) for i, n, _ in compliance.lengthranges] == [(0, "shoulder_muscle"), (1, "elbow_muscle")]
    compliant = spec.compile()
    np.testing.assert_array_equal(compliant.actuator_lengthrange, rigid.actuator_lengthrange)
    data = mujoco.MjData(compliant)
    data.ctrl[:] = 1.0
    mujoco.mj_step(compliant, data, 200)
    assert np.all(np.isfinite(data.qpos)) and np.all(data.actuator_force < 0)  # muscles pull
    mjflex.make_rigid(spec, compliance)
    assert all(not np.any(a.lengthrange) for a in spec.actuators)
    np.testing.assert_array_equal(spec.compile().actuator_lengthrange, rigid.actuator_lengthrange)
