"""The element forces of mjflex as Warp kernels, in float32 or float64 (one set of kernels per precision).

A new implementation of the formulas of the C engine (``mjflex/native/flexure_kernel.h``,
``evaluate.h``; derivations in :mod:`mjflex.core`), one thread per (world, element):

* pose: ``q_ab`` from MuJoCo Warp's body quaternions and the sites' local orientations (rest
  offset folded into ``qb``), ``w >= 0``; ``p_ab = R_Wa^T (p_b* - p_a)``;
* coordinates: the finite twist (rotation vector ``tau`` by ``atan2``, ``t = P p``) or the dual
  quaternion ``[xi; x']``; the twist map's scalars ``c(alpha)``, ``g(alpha)`` by their series in
  ``alpha^2`` below 2.2 rad (coefficients from Bernoulli numbers) and closed forms above;
* wrench: ``-Gamma_ab (K [tau; t] + B rate + grad terms)`` (twist) or
  ``-2 Lambda_ab (K [xi; x'] + B rate + terms / 4)`` (dual quaternion), the maps applied as
  dual-number maps exactly as in the C kernel;
* end stops (:mod:`mjflex.core.stops`): on the stop coordinates ``z = [tau; p_ab]`` (both
  methods), energy ``sum k_i / 2 overshoot_i^2`` and, added to the element's wrench on B,
  ``m = -P(tau) G_tau``, ``f = -R_ab^T G_p`` (``G`` the energy's gradient in ``z``), as the C
  kernel's ``mjfx_stop_wrench``; an element without stops in every world skips them at one
  per-element flag (``Params.stops``), read outside the element math; damped stops
  (``Params.stop_damped``) add ``b zdot`` beyond a limit, with ``zdot = [P(tau)^T w; R_ab v]``,
  clamped at zero so that a stop never attracts (the C kernel's ``mjfx_stop_damped``);
* rest pose: folded into the rest offset (``qb``, ``p0``) by the C reader; the wrench query of an
  element with a rest pose gives the moment about site b (``I_REST``), as the C engine's;
* generalized forces: a free body takes the world force and the moment about its origin in its
  own axes; any other body maps the wrench through its chain of dofs (``cdof``).

Kinematics come from MuJoCo Warp in float32 (its only precision): the float64 kernels convert
them once and do the element math and the sums in float64, then add float32 results to
``qfrc_passive``.

Forces are summed per dof in a fixed order (a gather over a table of contributions, no atomic
adds), so a run is reproducible bit for bit on one device.
"""

import warp as wp

#: Terms of the series of c and g in alpha^2 (alpha < 2.2 rad: the 21st term is below 1e-17 of the first).
NSERIES = 20
SERIES_THRESHOLD = 2.2
TWIST = 0
#: Kinds of a contribution to a dof: a free body's force or moment component, or a chain dof.
FORCE, MOMENT, CHAIN = 0, 1, 2
#: Integer columns of an element.
I_BODY_A, I_BODY_B, I_SITE_A, I_SITE_B, I_METHOD, I_ROOT_A, I_ROOT_B, I_FREE_A, I_FREE_B, I_LO, I_HI, I_REST, I_NCOL = (
    range(13)
)


def build(real, with_stops=True):
    """The kernels of one precision (``wp.float32`` or ``wp.float64``): a dict of Warp kernels and types.

    ``with_stops=False`` leaves the end stops' code out of the kernels (what the flag check costs elements without
    stops is measured against it: ``scripts/bench_warp_stops.py``); mjflex runs the kernels with stops.
    """
    V3 = wp.types.vector(3, real)
    V6 = wp.types.vector(6, real)
    V8 = wp.types.vector(8, real)
    Q4 = wp.types.vector(4, real)
    M33 = wp.types.matrix((3, 3), real)
    M66 = wp.types.matrix((6, 6), real)

    @wp.struct
    class Elements:
        ints: wp.array2d(dtype=wp.int32)  # I_* columns
        qa: wp.array(dtype=Q4)  # site a's orientation in body A (w-first)
        qb: wp.array(dtype=Q4)  # site b's orientation in body B times the rest offset's inverse
        p0: wp.array(dtype=V3)  # rest offset: position of frame b seen from frame a at qpos0
        lever_a: wp.array(dtype=V3)  # origin of frame a in body A
        lever_b: wp.array(dtype=V3)  # origin of frame b* in body B
        inv_mass: wp.array(dtype=real)
        inv_inertia: wp.array(dtype=real)
        exps: wp.array2d(dtype=wp.int32)  # (M, 8) exponents of the polynomial terms
        coefs: wp.array(dtype=real)
        series_c: wp.array(dtype=real)  # NSERIES coefficients of c and g in alpha^2
        series_g: wp.array(dtype=real)

    @wp.struct
    class Params:
        """Per-world parameters: leading dimension 1 (shared) or the number of worlds."""

        K: wp.array2d(dtype=M66)
        B: wp.array2d(dtype=M66)
        enabled: wp.array2d(dtype=wp.int32)
        viscous: wp.array2d(dtype=wp.int32)
        stop_lo: wp.array2d(dtype=V6)  # end stops' limits on [tau; p_ab], -inf / +inf: none
        stop_hi: wp.array2d(dtype=V6)
        stop_k: wp.array2d(dtype=V6)  # their stiffness (read where a limit is finite)
        stops: wp.array(dtype=wp.int32)  # (n,): 1 when the element has a stop in some world
        stop_b: wp.array2d(dtype=V6)  # the stops' damping (leading dimension 1: the model's)
        stop_damped: wp.array(dtype=wp.int32)  # (n,): 1 when the element's stops are damped

    @wp.struct
    class Out:
        """Per (world, element): what the gather, the watch and the queries read."""

        mo: wp.array2d(dtype=V3)  # moment about pb, world axes
        f: wp.array2d(dtype=V3)  # force, world axes
        mom_a: wp.array2d(dtype=V3)  # A: moment about its origin in its axes (free) or about its root's com (chain)
        mom_b: wp.array2d(dtype=V3)
        power: wp.array2d(dtype=real)
        accel: wp.array2d(dtype=wp.float32)
        finite: wp.array2d(dtype=wp.int32)

    @wp.func
    def quat_in(q: wp.quat) -> Q4:
        return Q4(real(q[0]), real(q[1]), real(q[2]), real(q[3]))

    @wp.func
    def vec_in(v: wp.vec3) -> V3:
        return V3(real(v[0]), real(v[1]), real(v[2]))

    @wp.func
    def qmul(a: Q4, b: Q4) -> Q4:
        return Q4(
            a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
            a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
            a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
            a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
        )

    @wp.func
    def qconj_mul(a: Q4, b: Q4) -> Q4:  # a^* b
        return Q4(
            a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3],
            a[0] * b[1] - a[1] * b[0] - a[2] * b[3] + a[3] * b[2],
            a[0] * b[2] + a[1] * b[3] - a[2] * b[0] - a[3] * b[1],
            a[0] * b[3] - a[1] * b[2] + a[2] * b[1] - a[3] * b[0],
        )

    @wp.func
    def qapply(q: Q4, v: V3, inverse: bool) -> V3:
        """R(q) v, or R(q)^T v: with t = 2 u x v, R v = v + w t + u x t, R^T v = v - w t + u x t."""
        u = V3(q[1], q[2], q[3])
        t = real(2.0) * wp.cross(u, v)
        wt = q[0] * t
        if inverse:
            wt = -wt
        return v + wt + wp.cross(u, t)

    @wp.func
    def qrot(q: Q4) -> M33:
        ww = q[0] * q[0]
        xx = q[1] * q[1]
        yy = q[2] * q[2]
        zz = q[3] * q[3]
        two = real(2.0)
        return M33(
            ww + xx - yy - zz, two * (q[1] * q[2] - q[0] * q[3]), two * (q[1] * q[3] + q[0] * q[2]),
            two * (q[1] * q[2] + q[0] * q[3]), ww - xx + yy - zz, two * (q[2] * q[3] - q[0] * q[1]),
            two * (q[1] * q[3] - q[0] * q[2]), two * (q[2] * q[3] + q[0] * q[1]), ww - xx - yy + zz,
        )  # fmt: skip

    @wp.func
    def angle_scalars(n2: real, w: real, el: Elements) -> V3:
        """(alpha / n, c(alpha), g(alpha)) of a unit quaternion with w >= 0 and |vector part|^2 = n2."""
        n = wp.sqrt(n2)
        s = real(2.0) / w
        if n > real(0.0):
            s = real(2.0) * wp.atan2(n, w) / n
        a = s * n
        c = real(0.0)
        g = real(0.0)
        if a < real(SERIES_THRESHOLD):
            x = a * a
            for k in range(NSERIES - 1, -1, -1):
                c = c * x + el.series_c[k]
                g = g * x + el.series_g[k]
        else:
            h = real(0.5) * a
            cot = w / n
            one_m = real(1.0) - h * cot
            dc_dh = (-cot + h / (n * n)) / (real(4.0) * h * h) - one_m / (real(2.0) * h * h * h)
            c = one_m / (a * a)
            g = dc_dh / (real(4.0) * h)
        return V3(s, c, g)

    @wp.func
    def pose(el: Elements, e: int, w: int, xquat: wp.array2d(dtype=wp.quat), site_xpos: wp.array2d(dtype=wp.vec3)):
        """(q_ab with w >= 0, p_ab, R_Wb*, p_Wb*)."""
        wa = qmul(quat_in(xquat[w, el.ints[e, I_BODY_A]]), el.qa[e])
        wb = qmul(quat_in(xquat[w, el.ints[e, I_BODY_B]]), el.qb[e])
        q = qconj_mul(wa, wb)
        if q[0] < real(0.0):
            q = -q
        Rb = qrot(wb)
        pb = vec_in(site_xpos[w, el.ints[e, I_SITE_B]]) - Rb @ el.p0[e]
        p = qapply(wa, pb - vec_in(site_xpos[w, el.ints[e, I_SITE_A]]), True)
        return q, p, Rb, pb

    @wp.func
    def coords(method: int, q: Q4, p: V3, el: Elements):
        """The coordinates [e1; e2] and what the maps need: (e1, e2, k0, k1, u0, u1, w, s')."""
        qv = V3(q[1], q[2], q[3])
        zero = V3(real(0.0), real(0.0), real(0.0))
        if method == TWIST:
            scal = angle_scalars(wp.dot(qv, qv), q[0], el)
            c = scal[1]
            g = scal[2]
            tau = scal[0] * qv
            a2 = wp.dot(tau, tau)
            k0 = real(1.0) - c * a2
            u0 = c * tau
            t = k0 * p - real(0.5) * wp.cross(tau, p) + wp.dot(tau, p) * u0
            e = wp.dot(tau, t)
            k1 = -e * (real(2.0) * c + g * a2)
            u1 = c * t + (g * e) * tau
            return tau, t, k0, k1, u0, u1, real(0.0), real(0.0)
        s_d = real(-0.5) * wp.dot(qv, p)
        x_d = real(0.5) * q[0] * p - real(0.5) * wp.cross(qv, p)
        return qv, x_d, real(0.0), real(0.0), zero, zero, q[0], s_d

    @wp.func
    def dual_map(
        method: int,
        e1: V3,
        e2: V3,
        k0: real,
        k1: real,
        u0: V3,
        u1: V3,
        w: real,
        s_d: real,
        sign: real,
        x0: V3,
        x1: V3,
    ):
        """The method's dual map of x0 + eps x1: Gamma's P^ (sign -1) or P^T (+1); Lambda (-1) or Lambda^T (+1)."""
        c0 = wp.cross(e1, x0)
        c12 = wp.cross(e1, x1) + wp.cross(e2, x0)
        if method == TWIST:
            h = real(0.5) * sign
            s0 = wp.dot(e1, x0)
            s1 = wp.dot(e1, x1) + wp.dot(e2, x0)
            o0 = k0 * x0 + h * c0 + s0 * u0
            o1 = k0 * x1 + k1 * x0 + h * c12 + s1 * u0 + s0 * u1
            return o0, o1
        return w * x0 + sign * c0, w * x1 + s_d * x0 + sign * c12

    @wp.func
    def mat6(M: M66, a: V3, b: V3):
        y = M @ V6(a[0], a[1], a[2], b[0], b[1], b[2])
        return V3(y[0], y[1], y[2]), V3(y[3], y[4], y[5])

    @wp.func
    def terms(method: int, z: V8, lo: int, hi: int, el: Elements, want_grad: bool):
        """Value and gradient dU/dz of the polynomial terms lo..hi at the coordinates z (6 or 8 used)."""
        nvar = 8
        if method == TWIST:
            nvar = 6
        grad = V8()
        value = real(0.0)
        for r in range(lo, hi):
            pw = V8()
            pm = V8()
            for i in range(nvar):
                v = real(1.0)
                for _k in range(el.exps[r, i] - 1):
                    v = v * z[i]
                pm[i] = v
                if el.exps[r, i] > 0:
                    pw[i] = v * z[i]
                else:
                    pw[i] = real(1.0)
            suffix = V8()
            acc = real(1.0)
            for j in range(nvar):
                i = nvar - 1 - j
                suffix[i] = acc
                acc = acc * pw[i]
            value = value + el.coefs[r] * acc
            if want_grad:
                prefix = el.coefs[r]
                for i in range(nvar):
                    ei = el.exps[r, i]
                    if ei > 0:
                        grad[i] = grad[i] + prefix * real(ei) * pm[i] * suffix[i]
                    prefix = prefix * pw[i]
        return value, grad

    @wp.func
    def coords8(method: int, e1: V3, e2: V3, w: real, s_d: real) -> V8:
        if method == TWIST:
            return V8(e1[0], e1[1], e1[2], e2[0], e2[1], e2[2], real(0.0), real(0.0))
        return V8(w, e1[0], e1[1], e1[2], s_d, e2[0], e2[1], e2[2])

    @wp.func
    def stop_rotation(method: int, q: Q4, e1: V3, k0: real, u0: V3, el: Elements):
        """tau and the scalars of P(tau) x = k0 x - tau x x / 2 + (tau . x) u0: the twist's own, else computed."""
        if method == TWIST:
            return e1, k0, u0
        qv = V3(q[1], q[2], q[3])
        scal = angle_scalars(wp.dot(qv, qv), q[0], el)
        tau = scal[0] * qv
        return tau, real(1.0) - scal[1] * wp.dot(tau, tau), scal[1] * tau

    @wp.func
    def stop_energy(par: Params, w: int, e: int, tau: V3, p: V3):
        """The end stops' energy at z = [tau; p] and its gradient G = dU/dz (rotation part, position part)."""
        lo = par.stop_lo[w % par.stop_lo.shape[0], e]
        hi = par.stop_hi[w % par.stop_hi.shape[0], e]
        k = par.stop_k[w % par.stop_k.shape[0], e]
        z = V6(tau[0], tau[1], tau[2], p[0], p[1], p[2])
        zero = real(0.0)
        g = V6()
        u = zero
        for i in range(6):
            over = wp.max(z[i] - hi[i], zero)
            under = wp.max(lo[i] - z[i], zero)
            u = u + k[i] * (over * over + under * under)
            g[i] = k[i] * (over - under)
        return real(0.5) * u, V3(g[0], g[1], g[2]), V3(g[3], g[4], g[5])

    @wp.func
    def stop_damped(par: Params, w: int, e: int, tau: V3, p: V3, zr: V3, zp: V3):
        """The damped stops' force G' at z = [tau; p] with rates [zr; zp] (rotation part, position part), and the
        power their damping dissipates (the C kernel's mjfx_stop_damped)."""
        lo = par.stop_lo[w % par.stop_lo.shape[0], e]
        hi = par.stop_hi[w % par.stop_hi.shape[0], e]
        k = par.stop_k[w % par.stop_k.shape[0], e]
        b = par.stop_b[w % par.stop_b.shape[0], e]
        z = V6(tau[0], tau[1], tau[2], p[0], p[1], p[2])
        r = V6(zr[0], zr[1], zr[2], zp[0], zp[1], zp[2])
        zero = real(0.0)
        g = V6()
        pwr = zero
        for i in range(6):
            over = wp.max(z[i] - hi[i], zero)
            under = wp.max(lo[i] - z[i], zero)
            eo = k[i] * over
            eu = k[i] * under
            bo = zero
            bu = zero
            if over > zero:
                bo = b[i]
            if under > zero:
                bu = b[i]
            go = wp.max(eo + bo * r[i], zero)
            gu = wp.max(eu - bu * r[i], zero)
            g[i] = go - gu
            pwr = pwr + ((go - eo) - (gu - eu)) * r[i]
        return V3(g[0], g[1], g[2]), V3(g[3], g[4], g[5]), pwr

    @wp.kernel(module="unique", enable_backward=False)
    def wrench_kernel(
        el: Elements,
        par: Params,
        spring_on: int,
        damper_on: int,
        xquat: wp.array2d(dtype=wp.quat),
        site_xpos: wp.array2d(dtype=wp.vec3),
        cvel: wp.array2d(dtype=wp.spatial_vector),
        subtree_com: wp.array2d(dtype=wp.vec3),
        out: Out,
    ):
        """Wrench of element e on its body B in world w (the C kernel's mjfx_kernel and group_wrench)."""
        w, e = wp.tid()
        zero = V3(real(0.0), real(0.0), real(0.0))
        if par.enabled[w % par.enabled.shape[0], e] == 0:
            out.mo[w, e] = zero
            out.f[w, e] = zero
            out.mom_a[w, e] = zero
            out.mom_b[w, e] = zero
            out.power[w, e] = real(0.0)
            out.accel[w, e] = 0.0
            out.finite[w, e] = 1
            return
        method = el.ints[e, I_METHOD]
        q, p, Rb, pb = pose(el, e, w, xquat, site_xpos)
        e1, e2, k0, k1, u0, u1, qw, s_d = coords(method, q, p, el)
        y1 = zero
        y2 = zero
        if spring_on != 0:
            y1, y2 = mat6(par.K[w % par.K.shape[0], e], e1, e2)
        pwr = real(0.0)
        viscous = damper_on != 0 and par.viscous[w % par.viscous.shape[0], e] != 0
        damped_stops = damper_on != 0 and spring_on != 0 and par.stop_damped[e] != 0
        w_rel = zero  # velocity of frame b* relative to frame a, b* axes
        v_rel = zero
        if viscous or damped_stops:
            ba = el.ints[e, I_BODY_A]
            bb = el.ints[e, I_BODY_B]
            ca = cvel[w, ba]
            cb = cvel[w, bb]
            wa = V3(real(ca[0]), real(ca[1]), real(ca[2]))
            wb = V3(real(cb[0]), real(cb[1]), real(cb[2]))
            va = V3(real(ca[3]), real(ca[4]), real(ca[5])) + wp.cross(
                wa, pb - vec_in(subtree_com[w, el.ints[e, I_ROOT_A]])
            )
            vb = V3(real(cb[3]), real(cb[4]), real(cb[5])) + wp.cross(
                wb, pb - vec_in(subtree_com[w, el.ints[e, I_ROOT_B]])
            )
            w_rel = wp.transpose(Rb) @ (wb - wa)
            v_rel = wp.transpose(Rb) @ (vb - va)
        if viscous:
            r1, r2 = dual_map(method, e1, e2, k0, k1, u0, u1, qw, s_d, real(1.0), w_rel, v_rel)
            if method != TWIST:
                r1 = real(0.5) * r1
                r2 = real(0.5) * r2
            b1, b2 = mat6(par.B[w % par.B.shape[0], e], r1, r2)
            pwr = wp.dot(r1, b1) + wp.dot(r2, b2)
            y1 = y1 + b1
            y2 = y2 + b2
        lo = el.ints[e, I_LO]
        hi = el.ints[e, I_HI]
        mb = zero
        fb = zero
        if spring_on != 0 and hi > lo:
            _value, grad = terms(method, coords8(method, e1, e2, qw, s_d), lo, hi, el, True)
            if method == TWIST:
                y1 = y1 + V3(grad[0], grad[1], grad[2])
                y2 = y2 + V3(grad[3], grad[4], grad[5])
                fb, mb = dual_map(method, e1, e2, k0, k1, u0, u1, qw, s_d, real(-1.0), y2, y1)
            else:
                quarter = real(0.25)
                y1 = y1 + quarter * V3(grad[1], grad[2], grad[3])
                y2 = y2 + quarter * V3(grad[5], grad[6], grad[7])
                ff, mm = dual_map(method, e1, e2, k0, k1, u0, u1, qw, s_d, real(-1.0), y2, y1)
                # the sigma and s' columns of eq. 116 (1/4: the scale -2 below stands for -1/2)
                mb = mm - (quarter * grad[0]) * e1 - (quarter * grad[4]) * e2
                fb = ff - (quarter * grad[4]) * e1
        else:
            fb, mb = dual_map(method, e1, e2, k0, k1, u0, u1, qw, s_d, real(-1.0), y2, y1)
        scale = real(-1.0)
        if method != TWIST:
            scale = real(-2.0)
            pwr = real(4.0) * pwr
        mb = scale * mb
        fb = scale * fb
        if wp.static(with_stops):
            if spring_on != 0 and par.stops[e] != 0:
                tau, sk0, su0 = stop_rotation(method, q, e1, k0, u0, el)
                _us, g1, g2 = stop_energy(par, w, e, tau, p)
                if damped_stops:  # rates: P(tau)^T w_rel, R_ab v_rel
                    zr = sk0 * w_rel + real(0.5) * wp.cross(tau, w_rel) + wp.dot(tau, w_rel) * su0
                    g1, g2, stop_pwr = stop_damped(par, w, e, tau, p, zr, qapply(q, v_rel, False))
                    pwr = pwr + stop_pwr
                mb = mb - (sk0 * g1 - real(0.5) * wp.cross(tau, g1) + wp.dot(tau, g1) * su0)
                fb = fb - qapply(q, g2, True)
        mo = Rb @ mb
        f = Rb @ fb
        out.mo[w, e] = mo
        if el.ints[e, I_REST] != 0:  # the wrench query's moment about site b
            out.mo[w, e] = mo + wp.cross(pb - vec_in(site_xpos[w, el.ints[e, I_SITE_B]]), f)
        out.f[w, e] = f
        out.power[w, e] = pwr
        total = mo[0] + mo[1] + mo[2] + f[0] + f[1] + f[2] + pwr
        out.finite[w, e] = int(wp.isfinite(total))
        am = wp.max(wp.max(wp.abs(f[0]), wp.abs(f[1])), wp.abs(f[2])) * el.inv_mass[e]
        ai = wp.max(wp.max(wp.abs(mo[0]), wp.abs(mo[1])), wp.abs(mo[2])) * el.inv_inertia[e]
        out.accel[w, e] = wp.float32(wp.max(am, ai))
        # the moments the gather maps: a free body's about its origin in its axes, else about its root's com
        if el.ints[e, I_FREE_B] != 0:
            Rl = qrot(el.qb[e])
            out.mom_b[w, e] = Rl @ mb + wp.cross(el.lever_b[e], Rl @ fb)
        else:
            out.mom_b[w, e] = mo + wp.cross(pb - vec_in(subtree_com[w, el.ints[e, I_ROOT_B]]), f)
        if el.ints[e, I_FREE_A] != 0:
            Rl = qrot(qmul(el.qa[e], q))
            lever = qapply(el.qa[e], p, False) + el.lever_a[e]
            out.mom_a[w, e] = Rl @ mb + wp.cross(lever, Rl @ fb)
        else:
            out.mom_a[w, e] = mo + wp.cross(pb - vec_in(subtree_com[w, el.ints[e, I_ROOT_A]]), f)

    @wp.kernel(module="unique", enable_backward=False)
    def gather_kernel(
        start: wp.array(dtype=wp.int32),
        element: wp.array(dtype=wp.int32),
        code: wp.array(dtype=wp.int32),
        out: Out,
        cdof: wp.array2d(dtype=wp.spatial_vector),
        diverged: wp.array(dtype=wp.int32),
        qfrc: wp.array2d(dtype=wp.float32),
    ):
        """Add the elements' generalized forces on dof j of world w, in a fixed order.

        ``code`` of a contribution: +-(1 + 4 kind + component), + for body B, - for body A.
        A world whose watch found a divergence gets NaN (it must never look like a result).
        """
        w, j = wp.tid()
        total = real(0.0)
        for k in range(start[j], start[j + 1]):
            e = element[k]
            c = code[k]
            sign = real(1.0)
            mom = out.mom_b[w, e]
            if c < 0:
                sign = real(-1.0)
                c = -c
                mom = out.mom_a[w, e]
            kind = (c - 1) // 4
            comp = (c - 1) % 4
            f = out.f[w, e]
            if kind == FORCE:
                total = total + sign * f[comp]
            elif kind == MOMENT:
                total = total + sign * mom[comp]
            else:
                d = cdof[w, j]
                total = total + sign * (
                    real(d[0]) * mom[0] + real(d[1]) * mom[1] + real(d[2]) * mom[2]
                    + real(d[3]) * f[0] + real(d[4]) * f[1] + real(d[5]) * f[2]
                )  # fmt: skip
        if diverged.shape[0] > 0:
            if diverged[w] >= 0:
                total = total + real(wp.nan)
        qfrc[w, j] = qfrc[w, j] + wp.float32(total)

    @wp.kernel(module="unique", enable_backward=False)
    def potential_kernel(
        el: Elements,
        par: Params,
        spring_on: int,
        xquat: wp.array2d(dtype=wp.quat),
        site_xpos: wp.array2d(dtype=wp.vec3),
        energy: wp.array2d(dtype=real),
        twist: wp.array2d(dtype=V6),
        stop_coords: wp.array2d(dtype=V6),
    ):
        """Elastic energy (end stops included) and finite twist [tau; t] of element e in world w (zeros when
        disabled, as the C engine's), and its stop coordinates [tau; p_ab] (also when disabled, as
        :meth:`mjflex.Flexures.stop_coordinates`)."""
        w, e = wp.tid()
        method = el.ints[e, I_METHOD]
        q, p, _Rb, _pb = pose(el, e, w, xquat, site_xpos)
        t1, t2, _c0, _c1, _c2, _c3, _c4, _c5 = coords(TWIST, q, p, el)
        stop_coords[w, e] = V6(t1[0], t1[1], t1[2], p[0], p[1], p[2])
        if par.enabled[w % par.enabled.shape[0], e] == 0:
            energy[w, e] = real(0.0)
            twist[w, e] = V6()
            return
        twist[w, e] = V6(t1[0], t1[1], t1[2], t2[0], t2[1], t2[2])
        e1, e2, _k0, _k1, _u0, _u1, qw, s_d = coords(method, q, p, el)
        u = real(0.0)
        if spring_on != 0:
            y1, y2 = mat6(par.K[w % par.K.shape[0], e], e1, e2)
            scale = real(0.5)
            if method != TWIST:
                scale = real(2.0)
            u = scale * (wp.dot(e1, y1) + wp.dot(e2, y2))
            lo = el.ints[e, I_LO]
            hi = el.ints[e, I_HI]
            if hi > lo:
                value, _grad = terms(method, coords8(method, e1, e2, qw, s_d), lo, hi, el, False)
                u = u + value
            if wp.static(with_stops):
                if par.stops[e] != 0:
                    us, _g1, _g2 = stop_energy(par, w, e, t1, p)
                    u = u + us
        energy[w, e] = u

    @wp.kernel(module="unique", enable_backward=False)
    def scalars_kernel(n2: wp.array(dtype=real), qw: wp.array(dtype=real), el: Elements, out: wp.array(dtype=V3)):
        """(alpha / n, c, g) of quaternions given by |vector part|^2 and w (for tests against the C engine)."""
        i = wp.tid()
        out[i] = angle_scalars(n2[i], qw[i], el)

    return {
        "real": real, "V3": V3, "V6": V6, "Q4": Q4, "M66": M66, "Elements": Elements, "Params": Params,
        "Out": Out, "wrench": wrench_kernel, "gather": gather_kernel, "potential": potential_kernel,
        "scalars": scalars_kernel,
    }  # fmt: skip


_BUILT = {}


def kernels(precision: str, with_stops: bool = True) -> dict:
    """The kernels of ``"float32"`` or ``"float64"`` (built once per process; compiled on first launch)."""
    key = (precision, with_stops)
    if key not in _BUILT:
        _BUILT[key] = build({"float32": wp.float32, "float64": wp.float64}[precision], with_stops)
    return _BUILT[key]
