"""The divergence watch of mjflex's MuJoCo Warp callback: one thread per world, after the element wrenches.

It counts each world's steps (from its time), judges its state and the elements' wrenches of this
evaluation, and keeps the first divergence of each run (see ``watch_kernel``); the callback then
makes that world's forces NaN (``mjflex/warp/_kernels.py``, the gather).
"""

import warp as wp

#: An element whose wrench alone accelerates one of its bodies beyond this [m/s^2, rad/s^2] is the
#: culprit of a bad state found soon after (as the C engine: a hundredth of MuJoCo's 1e10).
CANDIDATE_ACCEL = 1e8
#: MuJoCo's bound on a sane qpos / qvel (mjMAXVAL).
MAXVAL = 1e10
#: What a world's divergence was: its first non-finite element wrench, or a bad qpos / qvel.
NONFINITE, BAD_QPOS, BAD_QVEL = 0, 1, 2


@wp.struct
class Watch:
    """Per-world divergence watch (see ``watch_kernel``)."""

    last_time: wp.array(dtype=wp.float32)
    step: wp.array(dtype=wp.int32)
    evals: wp.array(dtype=wp.int32)
    cand_element: wp.array(dtype=wp.int32)
    cand_accel: wp.array(dtype=wp.float32)
    cand_step: wp.array(dtype=wp.int32)
    element: wp.array(dtype=wp.int32)  # -1: no flexure to blame
    kind: wp.array(dtype=wp.int32)
    at_step: wp.array(dtype=wp.int32)  # -1: the world has not diverged
    time: wp.array(dtype=wp.float32)
    accel: wp.array(dtype=wp.float32)


@wp.kernel(module="unique", enable_backward=False)
def watch_kernel(
    time: wp.array(dtype=wp.float32),
    timestep: wp.array(dtype=wp.float32),
    qpos: wp.array2d(dtype=wp.float32),
    qvel: wp.array2d(dtype=wp.float32),
    accel: wp.array2d(dtype=wp.float32),
    finite: wp.array2d(dtype=wp.int32),
    watch: Watch,
):
    """One world: count its steps, then judge the state and the elements' wrenches of this evaluation.

    A step starts when the world's time changes (MuJoCo Warp keeps it through the stages of RK4);
    time running backwards starts a new run (a reset) and clears the world's record. The first
    divergence of a run is kept: a qpos or qvel not finite or beyond MuJoCo's 1e10 is blamed on the
    element whose force alone accelerated a body beyond 1e8 in that step or the one before (-1 if
    none), else a non-finite wrench at a finite state is blamed on its element.
    """
    w = wp.tid()
    t = time[w]
    h = timestep[w % timestep.shape[0]]
    last = watch.last_time[w]
    if t != last:
        if watch.evals[w] < 0 or t < last:
            if t < last:  # a reset: a new run
                watch.at_step[w] = -1
                watch.element[w] = -1
                watch.cand_element[w] = -1
            watch.step[w] = wp.int32(wp.round(t / h))
        else:
            watch.step[w] = watch.step[w] + wp.max(1, wp.int32(wp.round((t - last) / h)))
        watch.evals[w] = 0
        watch.last_time[w] = t
    else:
        watch.evals[w] = watch.evals[w] + 1
    if watch.at_step[w] >= 0:
        return
    step = watch.step[w]
    bad = wp.int32(-1)
    for i in range(qpos.shape[1]):
        if not (wp.abs(qpos[w, i]) <= MAXVAL):
            bad = BAD_QPOS
    if bad < 0:
        for i in range(qvel.shape[1]):
            if not (wp.abs(qvel[w, i]) <= MAXVAL):
                bad = BAD_QVEL
    if bad >= 0:
        # found at a step's first evaluation: the step before made it
        made = step
        if watch.evals[w] == 0:
            made = step - 1
        watch.kind[w] = bad
        watch.time[w] = t
        if watch.cand_element[w] >= 0 and watch.cand_step[w] >= made - 1:
            watch.element[w] = watch.cand_element[w]
            watch.at_step[w] = watch.cand_step[w]
            watch.accel[w] = watch.cand_accel[w]
        else:
            watch.element[w] = -1
            watch.at_step[w] = wp.max(made, 0)
            watch.accel[w] = 0.0
        return
    best = wp.float32(0.0)
    culprit = wp.int32(-1)
    for e in range(accel.shape[1]):
        if finite[w, e] == 0:
            watch.element[w] = e
            watch.kind[w] = NONFINITE
            watch.at_step[w] = step
            watch.time[w] = t
            watch.accel[w] = wp.inf
            return
        if accel[w, e] > best:
            best = accel[w, e]
            culprit = e
    if watch.cand_element[w] >= 0 and watch.cand_step[w] < step - 1:
        watch.cand_element[w] = -1
    if culprit >= 0 and best > CANDIDATE_ACCEL and (watch.cand_element[w] < 0 or best >= watch.cand_accel[w]):
        watch.cand_element[w] = culprit
        watch.cand_accel[w] = best
        watch.cand_step[w] = step
