"""Models and a subprocess runner for the tests of the native engine's robustness (lifecycle, fuzzing, sanitizers).

The models are MJCF text written here (``mjflex.flexure`` instances with their configuration), so that
a child process needs nothing but ``import mujoco`` (which registers the plugin) to load them: no
numba, no mjflex. Code that may crash the process runs through :func:`run_python` in a child, so
that a crash fails one test instead of ending the suite.
"""

import os
import subprocess
import sys
import textwrap

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

#: Diagonal stiffness of the elements (rotation N m/rad, translation N/m); element i gets (i + 1) times it.
K_DIAG = (0.5, 0.7, 0.6, 80.0, 120.0, 100.0)
B_DIAG = (0.01, 0.014, 0.012, 1.6, 2.4, 2.0)

#: What a sanitizer prints when it finds something (any of them fails a run).
SANITIZER_REPORTS = ("ERROR: AddressSanitizer", "runtime error:", "WARNING: ThreadSanitizer", "ERROR: LeakSanitizer")


def _instances(n, site_a="a", site_b="b", method="twist", extra="", scale=1.0):
    out = []
    for i in range(n):
        K = " ".join(repr(scale * (i + 1) * k) for k in K_DIAG)
        B = " ".join(repr(b) for b in B_DIAG)
        out.append(
            f'<instance name="e{i}"><config key="site_a" value="{site_a}"/><config key="site_b" value="{site_b}"/>'
            f'<config key="method" value="{method}"/><config key="K" value="{K}"/><config key="B" value="{B}"/>'
            f"{extra}</instance>"
        )
    return "".join(out)


def two_body_xml(n=1, *, method="twist", mocap=False, sleep=False, site_b_pos="-0.0821053 0.0173684 0.0621053",
                 name="two_body", attached=False, scale=1.0):  # fmt: skip
    """Bodies A (free, or mocap) and B (free) joined at one point by ``n`` elements ``e0..`` on the same two sites.

    Models of different ``n`` have the same bodies, joints and sites (equal nq, nv, nsite): only their plugin
    instances differ, as in the issue's ``rollout`` with a model list. ``attached``: body B references ``e0``
    (``MjSpec.attach`` keeps only instances that a body references). ``scale`` multiplies every K.
    """
    option = '<option gravity="0 0 0"><flag sleep="enable"/></option>' if sleep else '<option gravity="0 0 0"/>'
    body_a = '<body name="A" pos="0 0 0.5" mocap="true">' if mocap else '<body name="A" pos="0 0 0.5"><freejoint/>'
    policy = "" if sleep else ' sleep="never"'
    plugin = '<plugin instance="e0"/>' if attached else ""
    return f"""<mujoco model="{name}">{option}
<extension><plugin plugin="mjflex.flexure">{_instances(n, method=method, scale=scale)}</plugin></extension>
<worldbody>
{body_a}<inertial pos="0 0 0" mass="1.3" diaginertia="0.01 0.014 0.018"/>
<geom size="0.03" contype="0" conaffinity="0" mass="0"/><site name="a" pos="0.1 0.02 0" quat="0.8 0 0.6 0"/></body>
<body name="B" pos="0.2 0.05 0.5" quat="0.923381 0.102598 -0.307794 0.205196"{policy}><freejoint/>{plugin}
<inertial pos="0 0 0" mass="0.8" diaginertia="0.006 0.011 0.007"/>
<geom size="0.03" contype="0" conaffinity="0" mass="0"/>
<site name="b" pos="{site_b_pos}" quat="0.554028 0.0410391 0.800263 -0.225715"/></body>
</worldbody></mujoco>"""


def plain_xml():
    """The bodies of :func:`two_body_xml` without any element (a model without the plugin)."""
    return two_body_xml(0).replace('<extension><plugin plugin="mjflex.flexure"></plugin></extension>', "")


def chain_xml(n_links=4, *, method="twist"):
    """A chain of hinge, slide and ball joints under the world; elements between neighbours at their joints, and one
    on a jointless body welded to a jointed one (its forces reach the joints through the dof chain)."""
    bodies, inst = [], []
    joints = (
        '<joint type="hinge" axis="0 1 0"/>',
        '<joint type="slide" axis="1 0 0"/><joint type="hinge" axis="1 0 1"/>',
        '<joint type="ball"/>',
    )
    for i in range(n_links):
        pos = "0 0 1" if i == 0 else "0 0 -0.1"
        bodies.append(
            f'<body name="l{i}" pos="{pos}">{joints[i % 3]}'
            f'<geom type="capsule" fromto="0 0 0 0.02 0 -0.08" size="0.01" contype="0" conaffinity="0"/>'
            f'<site name="s{i}" pos="0 0 -0.1"/>' + (f'<site name="t{i}" pos="0 0 0"/>' if i else "")
        )
    bodies.append('<body name="tip" pos="0 0 -0.1"><geom size="0.02" contype="0" conaffinity="0"/>'
                  '<site name="tip" pos="0 0 0"/></body>')  # fmt: skip
    xml = "".join(bodies) + "</body>" * n_links
    for i in range(1, n_links):
        K = " ".join(repr(0.01 * k) for k in K_DIAG)
        inst.append(f'<instance name="j{i}"><config key="site_a" value="s{i - 1}"/><config key="site_b" value="t{i}"/>'
                    f'<config key="method" value="{method}"/><config key="K" value="{K}"/></instance>')  # fmt: skip
    inst.append('<instance name="tip"><config key="site_a" value="ground"/><config key="site_b" value="tip"/>'
                f'<config key="method" value="{method}"/><config key="K" value="1 1 1 5 5 5"/></instance>')  # fmt: skip
    ground = f'<site name="ground" pos="0 0 {1 - 0.1 * n_links}"/>'
    return (f'<mujoco model="chain"><option gravity="0 0 0"/><extension><plugin plugin="mjflex.flexure">{"".join(inst)}'
            f"</plugin></extension><worldbody>{ground}{xml}</worldbody></mujoco>")  # fmt: skip


def arm_xml(kind, k=(0.3, 0.2)):
    """A planar two-link arm (hinges about z at the shoulder and the elbow, no gravity) with a muscle on a tendon
    across each joint, whose ``actuator_lengthrange`` MuJoCo's compiler computes by simulation.

    ``kind``: ``"element"``, an element in parallel with each hinge (sites on the joint's axis, frames aligned
    with it), stiffness ``k[j]`` (N m/rad) about z and stiff in the other directions, which the hinge does
    not allow (no force there); ``"spring"``, MuJoCo's hinge springs of stiffness ``k[j]`` instead: the same
    forces (a twist of a rotation about the frame's z axis is that angle); ``"plain"``: neither.
    """
    stiffness = [f' stiffness="{kj!r}"' if kind == "spring" else "" for kj in k]
    extension = ""
    if kind == "element":
        joints = (("world_axis", "upper_axis"), ("upper_tip", "lower_axis"))
        extension = (
            '<extension><plugin plugin="mjflex.flexure">'
            + "".join(
                f'<instance name="{name}"><config key="site_a" value="{a}"/><config key="site_b" value="{b}"/>'
                f'<config key="K" value="2 2 {kj!r} 500 500 500"/></instance>'
                for name, (a, b), kj in zip(("shoulder_element", "elbow_element"), joints, k, strict=True)
            )
            + "</plugin></extension>"
        )
    return f"""<mujoco model="arm_{kind}"><option timestep="0.002" gravity="0 0 0"/>{extension}
<worldbody><site name="world_axis"/><site name="origin" pos="-0.05 0.03 0"/>
<body name="upper"><joint name="shoulder" axis="0 0 1"{stiffness[0]}/>
<geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" contype="0" conaffinity="0"/>
<site name="upper_axis"/><site name="upper_tip" pos="0.3 0 0"/>
<site name="insertion" pos="0.1 -0.02 0"/><site name="upper_origin" pos="0.05 0.02 0"/>
<body name="lower" pos="0.3 0 0"><joint name="elbow" axis="0 0 1"{stiffness[1]}/>
<geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" contype="0" conaffinity="0"/>
<site name="lower_axis"/><site name="lower_insertion" pos="0.1 0.02 0"/></body></body></worldbody>
<tendon><spatial name="across_shoulder"><site site="origin"/><site site="insertion"/></spatial>
<spatial name="across_elbow"><site site="upper_origin"/><site site="lower_insertion"/></spatial></tendon>
<actuator><muscle name="shoulder_muscle" tendon="across_shoulder"/><muscle name="elbow_muscle" tendon="across_elbow"/>
</actuator></mujoco>"""


def sanitizer_reports(text):
    """The sanitizer reports in a process's output (empty: none)."""
    return [line for line in text.splitlines() if any(r in line for r in SANITIZER_REPORTS)]


def run_python(code, *, timeout=180, env=None, check=True):
    """Run ``code`` in a fresh interpreter at the repository root; returns the CompletedProcess.

    With ``check``, a non-zero exit status (a crash: -11 is SIGSEGV, -6 SIGABRT), a timeout (a hang) or any
    sanitizer report fails the calling test with the child's output.
    """
    import pytest

    environment = {**os.environ, "PYTHONPATH": ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""), **(env or {})}
    try:
        result = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], cwd=ROOT, env=environment,
                                capture_output=True, text=True, timeout=timeout)  # fmt: skip
    except subprocess.TimeoutExpired as exc:
        pytest.fail(f"the child hung (no exit within {timeout} s); output so far:\n{exc.stdout}\n{exc.stderr}")
    out = result.stdout + result.stderr
    if check:
        reports = sanitizer_reports(out)
        assert result.returncode == 0 and not reports, f"the child exited with {result.returncode}:\n{out[-6000:]}"
    return result


def step_pickled(blob, nstep):
    """Unpickle ``(model, data)`` and step the data: for a pickled MjData in another process (spawn)."""
    import pickle

    import mujoco
    import numpy as np

    m, d = pickle.loads(blob)
    mujoco.mj_step(m, d, nstep)
    return np.r_[d.qpos, d.qvel]
