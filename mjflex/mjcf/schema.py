"""How a flexure element is stored in an MJCF model file.

An element named ``E`` (any text) is

* two sites, ``E/a`` on body A and ``E/b`` on body B, at the same world pose in the model's
  reference configuration (``qpos0``): the element frame. ``E.a`` and ``E.b`` are read as
  well: dm_control's ``mjcf`` rejects ``/`` in names (it reserves it for its scopes);
* a custom text record ``<text name="mjflex:E" data="{...}"/>`` whose data is a JSON object
  with the keys

  - ``"mjflex"``: schema version, ``1`` (required);
  - ``"method"``: ``"twist"`` (default) or ``"dualquat"``;
  - ``"K"``: stiffness in the element frame (required): a 6x6 nested list or 6 numbers (the
    diagonal); 3x3 / 3 numbers for a planar element ``[theta_z; x; y]`` in the frame's x-y
    plane;
  - ``"B"``: damping, same layout as ``K`` (default: none, purely elastic);
  - ``"order"`` and ``"terms"``: a higher-order potential (:mod:`mjflex.core.polynomial`):
    ``"order"`` is its order N (an integer >= 2, even for ``"dualquat"``; default 2, the
    quadratic potential of ``K``) and ``"terms"`` the polynomial terms added to ``K``'s energy,
    ``{"exponents": [[...], ...], "coefficients": [...]}``: one row of 6 (twist: ``tau, t``) or
    8 (dual quaternion: ``sigma, xi, s', x'``) exponents per term, in the coordinates of
    ``"method"`` (also for planar elements), degrees at most ``"order"``. ``"terms"`` needs
    ``"order"``; what :func:`mjflex.fit_potential` returns goes in as
    ``fit.terms.to_dict()`` (less its ``"method"``);
  - ``"enabled"``, ``"viscous"``: run-time switches, ``true`` (default) or ``false``;
  - ``"strain_per_radian"``: peak bending strain per radian about the frame's z axis, used in
    reports and strain colours (optional);
  - ``"strain_scale"``: the full scale of the element's strain colour in MuJoCo's viewer (the
    engine plugin's drawing): the bending strain shown red, or, without ``"strain_per_radian"``,
    the rotation about z [rad] shown red (optional; default ``DEFAULT_STRAIN_SCALE`` = 1 % strain,
    or ``DEFAULT_ROTATION_SCALE`` = 0.1 rad);
  - ``"source"``: any JSON object recording where ``K`` came from (geometry, material,
    formula); kept verbatim (optional);
  - ``"site"``: the name of a site that gives the element frame, e.g. a robot's
    ``"wrist_site"`` (optional; written by ``add_flexure(..., site=...)``). The element's sites
    must then coincide with it at ``qpos0`` (the same tolerances as between the two sites), so a
    site moved in the file without its element is reported rather than silently ignored. Under
    ``MjSpec.attach`` the name is read with the element's prefix and suffix;
  - ``"stops"``: end stops, one-sided limits on the element's coordinates (optional;
    :class:`mjflex.Stops`, math in :mod:`mjflex.core.stops`): an object
    ``{"lower": [...], "upper": [...], "stiffness": ...}`` whose lists have one entry per
    coordinate, ``[rx, ry, rz, x, y, z]`` (rotation vector of frame b in frame a [rad], position
    of frame b in frame a [m]) or ``[theta, x, y]`` for a planar element, ``null`` where a
    coordinate has no stop; ``"stiffness"`` [N m/rad, N/m] is absent or ``null`` (derived:
    100 times ``K``'s diagonal entry of each coordinate), a number, or one per coordinate;
    ``"damping"`` [N m s/rad, N s/m] is absent or ``null`` (conservative stops), a number, or
    one per coordinate;
  - ``"rest"``: the rest pose, ``{"pos": [x, y, z], "quat": [w, x, y, z]}``: the pose of frame b
    in frame a at which the element's energy is zero [m; unit quaternion] (optional; default:
    the frames coincide, as compiled). Energies, wrenches and stop coordinates count from it
    (:mod:`mjflex.core.rest`); a rest pose the model does not hold preloads the element.

Validation rules (:func:`parse_text`; one place, mirrored by any other reader of records):

1. the data is strict JSON (RFC 8259): one object, no key given twice in any object, no
   ``NaN``/``Infinity``/``-Infinity`` anywhere (Python's ``json`` accepts them; other readers
   do not), nesting at most as deep as Python's recursion allows;
2. the element name (the text after ``mjflex:``) is not empty;
3. only the keys above; ``"mjflex"`` is the integer ``1`` (not ``true``, not ``1.0``);
4. ``"method"`` is one of the two strings; ``"enabled"``, ``"viscous"`` are ``true`` or
   ``false`` (not ``"false"``, not ``0``);
5. ``"K"`` (required) and ``"B"`` (optional, ``null`` = none) are lists of 6 or 3 numbers or
   6x6 / 3x3 nested lists; every entry is a JSON number (not a boolean, a string or
   ``null``), finite, at most ``MAX_MATRIX_ENTRY`` in magnitude (so a 401-digit integer is
   refused, not overflowed); the matrix is symmetric and positive semi-definite to the
   tolerances of :mod:`mjflex.core.validation`; ``B`` has ``K``'s size;
6. ``"order"`` is an integer (not a boolean) from 2 to ``MAX_ORDER``, even for ``"dualquat"``;
   ``"terms"`` needs it and is an object with exactly ``"exponents"`` (whole numbers, ``2`` or
   ``2.0``, from 0 to :data:`mjflex.core.polynomial.MAX_EXPONENT`; not booleans) and
   ``"coefficients"`` (finite numbers), the rules of :class:`mjflex.core.polynomial.PolynomialTerms`
   (degrees from 2 to ``"order"``, distinct rows, even and unstressed at rest for ``"dualquat"``),
   and ``K`` plus the terms' stiffness at rest is positive semi-definite;
7. ``"strain_per_radian"`` is ``null`` or a finite number >= 0 (not a boolean);
   ``"strain_scale"`` is ``null`` or a finite number > 0;
8. ``"source"`` is ``null`` or an object (any content within rule 1);
9. ``"site"`` is ``null`` or a non-empty string naming a site of the model (checked by
   :class:`mjflex.Flexures`: the element frame must coincide with it at ``qpos0``);
10. ``"stops"`` is ``null`` or an object with only the keys ``"lower"``, ``"upper"``,
    ``"stiffness"``: as many limits as ``K`` has rows, numbers or ``null``, none NaN; rotation
    limits within ``[-pi, pi]`` (radians, not degrees); ``lower <= upper``; the stiffness finite,
    ``>= 0``, and positive on every coordinate with a limit (a derived one needs ``K_ii > 0``);
    no stiffness without a limit; the damping finite and ``>= 0``, none without a limit
    (:mod:`mjflex.mjcf.stops` has the rules);
11. ``"rest"`` is ``null`` or an object with only the keys ``"pos"`` (3 finite numbers) and
    ``"quat"`` (4 finite numbers of norm 1 within :data:`mjflex.core.rest.REST_QUAT_TOLERANCE`), either optional.

Every violation raises ValueError naming the key (and entry), quoting the bad value cut to
:data:`mjflex.core.validation.SHORT_REPR` characters, and saying what is allowed; the model
layer adds the element's name (:class:`mjflex.ModelError`).

Units are SI and the row order is ``[rotation; translation]`` (``N m/rad``, ``N/rad``,
``N/m``; damping per unit rate). A text record rather than ``<numeric>`` keeps every digit:
MuJoCo writes numeric data with 6 significant digits but text verbatim, so ``K`` and ``B``
survive ``MjSpec.to_xml()`` and ``mj_saveLastXML`` exactly. Site poses do get rounded to 6
digits by those writers; :class:`mjflex.Flexures` accepts frames that coincide within
``COINCIDENCE_RTOL`` of the model extent (and ``COINCIDENCE_ANGLE`` rad) and takes the measured
residual as the rest offset, so a saved and reloaded model is unstressed at ``qpos0`` too.

Composed models: ``MjSpec.attach(child, prefix=P, suffix=S)`` renames the child's records to
``P + "mjflex:" + E + S`` and its sites to ``P + E + "/a" + S``; dm_control's ``attach``
prefixes both with ``"model_name/"``. Such a record is matched to its sites by the name around
``mjflex:`` (:func:`match_record`), and the element is called ``P + E + S``.

Example (hand-written)::

    <site name="hinge/a" pos="0 0 0.1"/>           <!-- in body A -->
    <site name="hinge/b" pos="0 0 -0.05"/>         <!-- in body B, same world point -->
    <custom>
      <text name="mjflex:hinge" data='{"mjflex": 1, "method": "twist",
            "K": [2.0, 40, 40, 1e6, 1e6, 3e6], "B": [1e-4, 0, 0, 0, 0, 0]}'/>
    </custom>

The same element as an engine plugin instance: :mod:`mjflex.mjcf.config`.
"""

import difflib
import json
from dataclasses import dataclass

import numpy as np

from ..core import validation
from ..core.polynomial import MAX_EXPONENT, PolynomialTerms
from ..core.rest import rest_pose
from ..core.stops import PLANAR_INDEX
from ..core.validation import MAX_MATRIX_ENTRY, shorten
from .stops import Stops

#: The two forms an element is written in: a text record, or an instance of the engine plugin.
RECORD, PLUGIN = "record", "plugin"
KINDS = (PLUGIN, RECORD)
#: Name of mjflex's engine plugin (:mod:`mjflex.mjcf.config` reads and writes its configuration).
PLUGIN_NAME = "mjflex.flexure"
PREFIX = "mjflex:"
SITE_A_SUFFIX = "/a"
SITE_B_SUFFIX = "/b"
#: Separators between an element's name and the ``a`` / ``b`` of its sites, in order of preference.
SITE_SEPARATORS = ("/", ".")
SCHEMA_VERSION = 1
KEYS = ("mjflex", "method", "K", "B", "order", "terms", "enabled", "viscous", "strain_per_radian", "strain_scale",
        "source", "site", "stops", "rest")  # fmt: skip
REST_KEYS = ("pos", "quat")
#: Full scale of an element's strain colour in the viewer when ``"strain_scale"`` is not given: 1 %
#: bending strain (where the elastic range of flexure metals ends: spring steel, titanium and
#: aluminium alloys yield at 0.5-1 %), or 0.1 rad of rotation for an element without ``"strain_per_radian"``.
DEFAULT_STRAIN_SCALE = 0.01
DEFAULT_ROTATION_SCALE = 0.1
TERMS_KEYS = ("exponents", "coefficients")
#: The two sites count as coincident when they are closer than this times the element's own
#: length scale: the summed lengths of the site and body positions that place both sites,
#: whose 6-significant-digit rounding by MuJoCo's XML writers (relative error <= 5e-6 per
#: number) is what the rest offset absorbs.
COINCIDENCE_RTOL = 1e-5
#: Angle [rad] below which the two site frames count as aligned.
COINCIDENCE_ANGLE = 1e-5
#: Highest ``"order"`` of a record's potential: every variable at its highest exponent (8 x 16).
MAX_ORDER = 8 * MAX_EXPONENT


@dataclass
class FlexureRecord:
    """The parameters of one element as stored in the model file.

    ``K`` and ``B`` are 6x6 (spatial) or 3x3 (planar); ``B`` is None without damping; ``terms``
    (in the coordinates of ``method``) is None for the quadratic potential. A
    :class:`mjflex.Flexures` holds one per element, in ``flex.records``.

    Attributes
    ----------
    name : str
        The element's name.
    method : {"twist", "dualquat"}
        How the relative displacement is measured.
    K : ndarray, shape (6, 6) or (3, 3)
        Stiffness in the element frame, rows ``[rotation; translation]`` (``[theta_z; x; y]``
        planar): N m/rad, N/rad, N/m.
    B : ndarray, shape (6, 6) or (3, 3), or None
        Damping, the layout of ``K`` (N m s/rad, N s/m); None without damping.
    enabled, viscous : bool
        The run-time switches as stored in the model.
    strain_per_radian : float or None
        Peak bending strain per radian about the frame's z axis, for reports.
    source : dict or None
        Where ``K`` came from, verbatim.
    terms : PolynomialTerms or None
        Higher-order terms of the potential (None: quadratic).
    order : int
        Order of the potential (2: quadratic).
    site : str or None
        The site that gives the element frame, if the element was placed at one.
    strain_scale : float or None
        Full scale of the element's strain colour in MuJoCo's viewer (bending strain, or rotation
        in rad without ``strain_per_radian``); None: the default (``DEFAULT_STRAIN_SCALE``).
    stops : Stops or None
        End stops on the element's coordinates (:class:`mjflex.Stops`); None: none.
    rest : tuple or None
        The rest pose ``((x, y, z), (w, x, y, z))``: the pose of frame b in frame a at which the
        element's energy is zero [m; unit quaternion], as written; None: the frames coincide.

    Examples
    --------
    >>> import mujoco
    >>> import mjflex
    >>> spec = mujoco.MjSpec.from_string(
    ...     '<mujoco><worldbody><body name="B"><freejoint/><geom size="0.01" mass="0.1"/></body></worldbody></mujoco>'
    ... )
    >>> _ = mjflex.add_flexure(spec, "mount", "world", "B", pos=[0, 0, 0], K=[1, 1, 1, 1e4, 1e4, 1e4], B=[1e-3] * 6)
    >>> record = mjflex.Flexures(spec.compile()).records[0]
    >>> print(record.name, record.method, record.K.shape, f"{record.K[3, 3]:g} N/m", record.planar)
    mount twist (6, 6) 10000 N/m False
    """

    name: str
    method: str
    K: np.ndarray
    B: np.ndarray | None = None
    enabled: bool = True
    viscous: bool = True
    strain_per_radian: float | None = None
    source: dict | None = None
    terms: PolynomialTerms | None = None
    order: int = 2
    site: str | None = None
    strain_scale: float | None = None
    stops: Stops | None = None
    rest: tuple | None = None

    @property
    def planar(self) -> bool:
        """True for a planar element (3×3 ``K`` over ``[theta; x; y]``), False for a spatial one (6×6)."""
        return self.K.shape == (3, 3)

    def to_text(self) -> str:
        """JSON data of the ``<text>`` record (full float precision)."""
        payload = {"mjflex": SCHEMA_VERSION, "method": self.method, "K": self.K.tolist()}
        if self.B is not None:
            payload["B"] = self.B.tolist()
        if self.terms is not None:
            payload["order"] = int(self.order)
            payload["terms"] = {k: v for k, v in self.terms.to_dict().items() if k != "method"}
        if not self.enabled:
            payload["enabled"] = False
        if not self.viscous:
            payload["viscous"] = False
        if self.strain_per_radian is not None:
            payload["strain_per_radian"] = float(self.strain_per_radian)
        if self.strain_scale is not None:
            payload["strain_scale"] = float(self.strain_scale)
        if self.source is not None:
            payload["source"] = self.source
        if self.site is not None:
            payload["site"] = self.site
        if self.stops:
            payload["stops"] = self.stops.to_dict()
        if self.rest is not None:
            payload["rest"] = {"pos": list(self.rest[0]), "quat": list(self.rest[1])}
        return json.dumps(payload)


def site_names(element: str) -> tuple[str, str]:
    """The canonical site names ``E/a``, ``E/b`` of element ``E`` (what ``add_flexure`` writes)."""
    return element + SITE_A_SUFFIX, element + SITE_B_SUFFIX


def match_record(text_name: str, sites) -> tuple[str, str, str, bool] | None:
    """The element a text record describes: ``(element, site a, site b, found)``, or None.

    ``text_name`` is ``P + "mjflex:" + E + S`` (``P``, ``S``: prefix and suffix added by
    ``MjSpec.attach`` or dm_control, usually empty); ``sites`` is the set of the model's site
    names. The sites are ``P + E + sep + "a" + S`` and ``... "b" + S`` for a separator in
    ``SITE_SEPARATORS``; the longest ``E`` whose two sites exist wins. When none exist,
    ``found`` is False and the canonical names (empty suffix, ``/``) are returned for the error.
    Raises ValueError when both spellings of one element exist.
    """
    i = text_name.find(PREFIX)
    if i < 0:
        return None
    head, rest = text_name[:i], text_name[i + len(PREFIX) :]
    for j in range(len(rest), -1, -1):
        element, tail = rest[:j], rest[j:]
        both = [
            (head + element + sep + "a" + tail, head + element + sep + "b" + tail)
            for sep in SITE_SEPARATORS
            if head + element + sep + "a" + tail in sites and head + element + sep + "b" + tail in sites
        ]
        if len(both) > 1:
            raise ValueError(f"both {both[0]} and {both[1]} exist; keep one spelling of the element's sites")
        if both:
            return head + element + tail, both[0][0], both[0][1], True
    return head + rest, head + rest + SITE_A_SUFFIX, head + rest + SITE_B_SUFFIX, False


def near_miss(text_name: str) -> bool:
    """Whether a text name without ``mjflex:`` looks like a misspelt record (``mjflx:``, ``MJFLEX:``, ``mjflex-``)."""
    if PREFIX in text_name:
        return False
    lower = text_name.lower()
    if "mjflex" in lower:
        return True
    windows = {lower[i : i + n] for n in (6, 7, 8) for i in range(max(len(lower) - n + 1, 1))}
    return any(difflib.SequenceMatcher(None, w, PREFIX).ratio() >= 0.8 for w in windows)


def orphan_site_pairs(sites, elements_sites) -> list[str]:
    """Names ``E`` with sites ``E/a`` and ``E/b`` (or ``E.a``, ``E.b``) that no record claims."""
    out = []
    for name in sorted(sites):
        for sep in SITE_SEPARATORS:
            if name.endswith(sep + "a") and name[:-1] + "b" in sites:
                if name not in elements_sites:
                    out.append(name[: -len(sep) - 1])
    return out


def embed_planar(M: np.ndarray) -> np.ndarray:
    """A planar 3x3 matrix ``[theta_z; x; y]`` as the 6x6 matrix of the same element."""
    out = np.zeros((6, 6))
    out[np.ix_(PLANAR_INDEX, PLANAR_INDEX)] = M
    return out


def element_matrix(value, key: str, *, n_allowed=(6, 3), what: str | None = None) -> np.ndarray:
    """A validated K or B: a square nested list or a diagonal list; raises ValueError with the fix.

    6x6 (6 diagonal entries) for a spatial element, 3x3 (3 entries) for a planar one; real numbers
    (rules of :func:`mjflex.core.validation.numeric_array`: no booleans, text, null, complex),
    finite, at most ``MAX_MATRIX_ENTRY`` in magnitude, symmetric and positive semi-definite.
    """
    if value is None:
        raise ValueError(f'"{key}" must be a list of numbers or a square nested list; got null/None')
    try:
        a = validation.numeric_array(value, key)
    except (TypeError, ValueError) as exc:
        raise ValueError(str(exc)) from None
    if a.ndim == 1 and a.shape[0] in n_allowed:
        a = np.diag(a)
    elif not (a.ndim == 2 and a.shape[0] == a.shape[1] and a.shape[0] in n_allowed):
        raise ValueError(
            f'"{key}" must be 6x6 (or 6 diagonal entries) for a spatial element, or 3x3 (3 entries) for a '
            f"planar one; got shape {a.shape}: {shorten(value)}"
        )
    finite = np.isfinite(a)
    if finite.all() and np.abs(a).max(initial=0.0) > MAX_MATRIX_ENTRY:
        r, c = np.unravel_index(np.argmax(np.abs(a)), a.shape)
        raise ValueError(
            f"{key}[{r}, {c}] = {a[r, c]:.3g} is beyond {MAX_MATRIX_ENTRY:g}, where the element's energy and "
            "forces overflow float64 for displacements MuJoCo accepts; check its units (SI: N m/rad, N/m)"
        )
    what = what or ("stiffness" if key.startswith("K") else "damping")
    return validation.check_psd_matrix(a, key, a.shape[0], what=what)


def _strict_object(pairs):
    """``json`` object hook: a dict, refusing a key given twice (``json`` would keep the last)."""
    out = {}
    for key, value in pairs:
        if key in out:
            raise ValueError(f"the key {shorten(key, 40)} is given twice in one object; keep one")
        out[key] = value
    return out


class _Constant(str):
    """A ``NaN``/``Infinity``/``-Infinity`` read by ``json``: kept as a marker to report with its key."""


def _find_constant(value, path=""):
    """The JSON path (``"K"[0][1]``, ``"source"["E"]``) and text of the first NaN or Infinity in ``value``, or None."""
    items = value.items() if isinstance(value, dict) else enumerate(value) if isinstance(value, list) else ()
    for key, v in items:
        where = (f'"{key}"' if not path else f'{path}["{key}"]') if isinstance(value, dict) else f"{path}[{key}]"
        if isinstance(v, _Constant):
            return where, str(v)
        found = _find_constant(v, where)
        if found:
            return found
    return None


def load_json(data: str):
    """The JSON value of a record's data under rule 1 (strict JSON); ValueError saying what is wrong."""
    try:
        payload = json.loads(data, object_pairs_hook=_strict_object, parse_constant=_Constant)
        found = _find_constant(payload)
    except json.JSONDecodeError as exc:
        raise ValueError(f"its data is not valid JSON ({exc.msg} at character {exc.pos})") from None
    except RecursionError:
        raise ValueError("its data nests JSON arrays or objects too deeply to be a flexure record") from None
    if isinstance(payload, _Constant) or found:
        where, text = found or ("its data", str(payload))
        raise ValueError(f"{where} is {text}, which is not a JSON number (strict JSON has no NaN or Infinity); "
                         "every number of a record must be finite")  # fmt: skip
    return payload


def _flag(payload, key):
    value = payload.get(key, True)
    if not isinstance(value, bool):
        raise ValueError(f'"{key}" must be true or false; got {shorten(value)}')
    return value


def _strain(payload, key="strain_per_radian"):
    strain = payload.get(key)
    if strain is None:
        return None
    ok = isinstance(strain, int | float) and not isinstance(strain, bool)
    positive = key == "strain_scale"
    if not (ok and abs(strain) <= MAX_MATRIX_ENTRY and (strain > 0 if positive else strain >= 0)):
        what = "> 0" if positive else ">= 0"  # huge integers are refused, not overflowed
        raise ValueError(f'"{key}" must be a finite number {what} (or null); got {shorten(strain)}')
    return float(strain)


def parse_text(element: str, data: str) -> FlexureRecord:
    """Parse the JSON data of an element's text record (rules in the module docstring); raises
    ValueError saying what to fix."""
    if not element:
        raise ValueError(
            f'the element name is empty (the record is named "{PREFIX}" with nothing after it); name the '
            f'element: <text name="{PREFIX}NAME"> with sites NAME/a and NAME/b'
        )
    payload = load_json(data)
    if not isinstance(payload, dict):
        raise ValueError(f'its data must be a JSON object such as {{"mjflex": 1, "K": [...]}}; got {shorten(payload)}')
    return parse_payload(element, payload)


def parse_payload(element: str, payload: dict) -> FlexureRecord:
    """A record from its decoded JSON object; raises ValueError saying what to fix."""
    unknown = sorted(set(payload) - set(KEYS))
    if unknown:
        raise ValueError(f"unknown key(s) {shorten(unknown)}; the allowed keys are {list(KEYS)}")
    version = payload.get("mjflex")
    if type(version) is not int or version != SCHEMA_VERSION:
        raise ValueError(
            f'"mjflex" must be the schema version {SCHEMA_VERSION}; got {shorten(version)} (an integer is needed)'
        )
    method = payload.get("method", "twist")
    if method not in ("twist", "dualquat"):
        raise ValueError(f'unknown method {shorten(method)}; use "twist" or "dualquat"')
    if "K" not in payload:
        raise ValueError('the stiffness "K" is missing')
    K = element_matrix(payload["K"], "K")
    B = None
    if payload.get("B") is not None:
        B = element_matrix(payload["B"], "B", n_allowed=(K.shape[0],))
    enabled, viscous = _flag(payload, "enabled"), _flag(payload, "viscous")
    strain = _strain(payload)
    source = payload.get("source")
    if source is not None and not isinstance(source, dict):
        raise ValueError(f'"source" must be a JSON object; got {shorten(source)}')
    site = payload.get("site")
    if site is not None and not (isinstance(site, str) and site):
        raise ValueError(f'"site" must be the name of a site of the model; got {shorten(site)}')
    order, terms = order_and_terms(payload, method, K)
    return FlexureRecord(element, method, K, B, enabled, viscous, strain, source, terms, order, site,
                         _strain(payload, "strain_scale"), _stops(payload, K), _rest(payload))  # fmt: skip


def checked_rest(rest, what="rest") -> tuple | None:
    """A rest pose ``(pos, quat)`` (or None) checked (:func:`mjflex.core.rest.rest_pose`) and kept as written:
    ``((x, y, z), (w, x, y, z))`` of floats; ValueError saying what is wrong."""
    if rest is None:
        return None
    rest_pose(rest, what)
    return tuple(float(v) for v in rest[0]), tuple(float(v) for v in rest[1])


def _rest(payload):
    """The record's rest pose (rule 11), or None."""
    data = payload.get("rest")
    if data is None:
        return None
    if not isinstance(data, dict) or set(data) - set(REST_KEYS):
        raise ValueError(f'"rest" must be an object with the keys "pos" ([x, y, z], m) and "quat" ([w, x, y, z], a '
                         f"unit quaternion): the pose of frame b in frame a at rest; got {shorten(data)}")  # fmt: skip
    for key, n in (("pos", 3), ("quat", 4)):
        if data.get(key) is not None and not (isinstance(data[key], list) and len(data[key]) == n):
            raise ValueError(f'"rest" "{key}" must be a list of {n} numbers; got {shorten(data[key])}')
    pos = data.get("pos") if data.get("pos") is not None else [0.0, 0.0, 0.0]
    quat = data.get("quat") if data.get("quat") is not None else [1.0, 0.0, 0.0, 0.0]
    return checked_rest((pos, quat), '"rest"')


def _stops(payload, K):
    """The record's end stops checked against its ``K`` (rule 10), or None."""
    if payload.get("stops") is None:
        return None
    stops = Stops.from_dict(payload["stops"])
    try:
        stops.stiffness_for(K)
    except ValueError as exc:
        raise ValueError(f'"stops": {exc}') from None
    return stops if stops else None


def order_and_terms(payload, method, K):
    """``(order, terms)`` of a record: validated polynomial terms, or ``(2, None)``."""
    order = payload.get("order", 2)
    integer = isinstance(order, int | np.integer) and not isinstance(order, bool)
    if not integer or not 2 <= order <= MAX_ORDER or (method == "dualquat" and order % 2):
        even = " and even for a dualquat element (its potential is even in q)" if method == "dualquat" else ""
        raise ValueError(f'"order" must be an integer >= 2{even}, at most {MAX_ORDER}; got {shorten(order)}')
    data = payload.get("terms")
    if data is None:
        if order != 2:
            raise ValueError(f'"order" is {order} but there are no "terms"; add the terms or drop "order"')
        return 2, None
    if "order" not in payload:
        raise ValueError('"terms" need the "order" of the potential (the highest degree of its terms)')
    if not isinstance(data, dict) or sorted(data) != sorted(TERMS_KEYS):
        raise ValueError(f'"terms" must be an object with exactly the keys {list(TERMS_KEYS)}; got {shorten(data)}')
    try:
        terms = PolynomialTerms.from_dict({"method": method, **data})
    except ValueError as exc:
        raise ValueError(f'"terms": {str(exc).rstrip(".")}') from None
    if terms.order > order:
        row = int(np.argmax(terms.exponents.sum(axis=1)))
        raise ValueError(
            f'"terms" exponents[{row}] has degree {terms.order}, above "order" {order}; raise "order" or drop the term'
        )
    H = terms.rest_stiffness()
    if np.any(H):
        K6 = embed_planar(K) if K.shape == (3, 3) else K
        validation.check_psd_matrix(K6 + H, "K + the terms' stiffness at rest", 6, what="stiffness")
    return order, terms


# ------------------------------------------------------------------------------ plugin instances
