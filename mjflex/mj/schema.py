"""How a flexure element is stored in an MJCF model file.

An element named ``E`` (any text) is

* two sites, ``E/a`` on body A and ``E/b`` on body B, at the same world pose in the model's
  reference configuration (``qpos0``): the element frame; and
* a custom text record ``<text name="mjflex:E" data="{...}"/>`` whose data is a JSON object
  with the keys

  - ``"mjflex"``: schema version, ``1`` (required);
  - ``"method"``: ``"twist"`` (default) or ``"dualquat"``;
  - ``"K"``: stiffness in the element frame (required): a 6x6 nested list or 6 numbers (the
    diagonal); 3x3 / 3 numbers for a planar element ``[theta_z; x; y]`` in the frame's x-y
    plane;
  - ``"B"``: damping, same layout as ``K`` (default: none, purely elastic);
  - ``"enabled"``, ``"viscous"``: run-time switches, ``true`` (default) or ``false``;
  - ``"strain_per_radian"``: peak bending strain per radian about the frame's z axis, used in
    reports (optional);
  - ``"source"``: any JSON object recording where ``K`` came from (geometry, material,
    formula); kept verbatim (optional).

Units are SI and the row order is ``[rotation; translation]`` (``N m/rad``, ``N/rad``,
``N/m``; damping per unit rate). A text record rather than ``<numeric>`` keeps every digit:
MuJoCo writes numeric data with 6 significant digits but text verbatim, so ``K`` and ``B``
survive ``MjSpec.to_xml()`` and ``mj_saveLastXML`` exactly. Site poses do get rounded to 6
digits by those writers; :class:`mjflex.Flexures` accepts frames that coincide within
``COINCIDENCE_RTOL`` of the model extent (and ``COINCIDENCE_ANGLE`` rad) and takes the measured
residual as the rest offset, so a saved and reloaded model is unstressed at ``qpos0`` too.

Example (hand-written)::

    <site name="hinge/a" pos="0 0 0.1"/>           <!-- in body A -->
    <site name="hinge/b" pos="0 0 -0.05"/>         <!-- in body B, same world point -->
    <custom>
      <text name="mjflex:hinge" data='{"mjflex": 1, "method": "twist",
            "K": [2.0, 40, 40, 1e6, 1e6, 3e6], "B": [1e-4, 0, 0, 0, 0, 0]}'/>
    </custom>
"""

import json
from dataclasses import dataclass

import numpy as np

PREFIX = "mjflex:"
SITE_A_SUFFIX = "/a"
SITE_B_SUFFIX = "/b"
SCHEMA_VERSION = 1
KEYS = ("mjflex", "method", "K", "B", "enabled", "viscous", "strain_per_radian", "source")
#: Relative (to the model extent) distance below which the two sites count as coincident.
COINCIDENCE_RTOL = 1e-5
#: Angle [rad] below which the two site frames count as aligned.
COINCIDENCE_ANGLE = 1e-5
#: Indices of the planar coordinates ``[theta_z; x; y]`` within ``[rx, ry, rz, x, y, z]``.
PLANAR_INDEX = (2, 3, 4)


@dataclass
class FlexureRecord:
    """The parameters of one element as stored in the model file.

    ``K`` and ``B`` are 6x6 (spatial) or 3x3 (planar); ``B`` is None without damping.
    """

    name: str
    method: str
    K: np.ndarray
    B: np.ndarray | None = None
    enabled: bool = True
    viscous: bool = True
    strain_per_radian: float | None = None
    source: dict | None = None

    @property
    def planar(self) -> bool:
        return self.K.shape == (3, 3)

    def to_text(self) -> str:
        """JSON data of the ``<text>`` record (full float precision)."""
        payload = {"mjflex": SCHEMA_VERSION, "method": self.method, "K": self.K.tolist()}
        if self.B is not None:
            payload["B"] = self.B.tolist()
        if not self.enabled:
            payload["enabled"] = False
        if not self.viscous:
            payload["viscous"] = False
        if self.strain_per_radian is not None:
            payload["strain_per_radian"] = float(self.strain_per_radian)
        if self.source is not None:
            payload["source"] = self.source
        return json.dumps(payload)


def site_names(element: str) -> tuple[str, str]:
    return element + SITE_A_SUFFIX, element + SITE_B_SUFFIX


def embed_planar(M: np.ndarray) -> np.ndarray:
    """A planar 3x3 matrix ``[theta_z; x; y]`` as the 6x6 matrix of the same element."""
    out = np.zeros((6, 6))
    out[np.ix_(PLANAR_INDEX, PLANAR_INDEX)] = M
    return out


def _matrix(value, key: str, element: str, n_allowed=(6, 3)) -> np.ndarray:
    """A square matrix from a nested list or a diagonal list; raises ValueError with the fix."""
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f'"{key}" must be a list of numbers or a square nested list; got {value!r}') from None
    if a.ndim == 1 and a.shape[0] in n_allowed:
        return np.diag(a)
    if a.ndim == 2 and a.shape[0] == a.shape[1] and a.shape[0] in n_allowed:
        return a
    raise ValueError(
        f'"{key}" must be 6x6 (or 6 diagonal entries) for a spatial element, or 3x3 (3 entries) for a '
        f"planar one; got shape {a.shape}"
    )


def parse_text(element: str, data: str) -> FlexureRecord:
    """Parse the JSON data of an element's text record; raises ValueError saying what to fix."""
    try:
        payload = json.loads(data)
    except json.JSONDecodeError as exc:
        raise ValueError(f"its data is not valid JSON ({exc.msg} at character {exc.pos})") from None
    if not isinstance(payload, dict):
        raise ValueError('its data must be a JSON object such as {"mjflex": 1, "K": [...]}')
    unknown = sorted(set(payload) - set(KEYS))
    if unknown:
        raise ValueError(f"unknown key(s) {unknown}; the allowed keys are {list(KEYS)}")
    if payload.get("mjflex") != SCHEMA_VERSION:
        raise ValueError(f'"mjflex" must be the schema version {SCHEMA_VERSION}; got {payload.get("mjflex")!r}')
    method = payload.get("method", "twist")
    if method not in ("twist", "dualquat"):
        raise ValueError(f'unknown method {method!r}; use "twist" or "dualquat"')
    if "K" not in payload:
        raise ValueError('the stiffness "K" is missing')
    K = _matrix(payload["K"], "K", element)
    B = None
    if payload.get("B") is not None:
        B = _matrix(payload["B"], "B", element, n_allowed=(K.shape[0],))
    for key in ("enabled", "viscous"):
        if not isinstance(payload.get(key, True), bool):
            raise ValueError(f'"{key}" must be true or false; got {payload[key]!r}')
    strain = payload.get("strain_per_radian")
    if strain is not None and not (isinstance(strain, int | float) and not isinstance(strain, bool) and strain >= 0):
        raise ValueError(f'"strain_per_radian" must be a non-negative number; got {strain!r}')
    source = payload.get("source")
    if source is not None and not isinstance(source, dict):
        raise ValueError(f'"source" must be a JSON object; got {source!r}')
    return FlexureRecord(element, method, K, B, payload.get("enabled", True), payload.get("viscous", True),
                         None if strain is None else float(strain), source)  # fmt: skip
