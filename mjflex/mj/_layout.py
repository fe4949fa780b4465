"""Byte offsets of the few ``mjData`` / ``mjModel`` fields that the native callback reads.

A C callback receives raw ``mjModel*`` / ``mjData*`` pointers. To read ``site_xpos`` etc. from
them without the Python bindings, we compute the C struct layout from MuJoCo's own
introspection tables (``mujoco.introspect``, generated from the headers of the installed
version) and then *verify* every offset against a live ``MjModel`` / ``MjData``: each pointer
field must hold the address of the array the bindings expose, and scalar fields must read back
values we write. If anything disagrees (a MuJoCo version whose layout we cannot reproduce),
:func:`verified_offsets` raises :class:`LayoutError` and the provider falls back to a Python
callback.
"""

import ctypes
import functools

import mujoco
import numpy as np
from mujoco.introspect import ast_nodes, enums, structs

DATA_POINTERS = ("site_xpos", "site_xmat", "xpos", "xmat", "cvel", "subtree_com", "cdof", "qfrc_passive")

_PRIMITIVES = {
    "char": 1, "unsigned char": 1, "mjtByte": 1, "mjtBool": 1,
    "int": 4, "unsigned int": 4, "float": 4,
    "mjtSize": 8, "size_t": 8, "uintptr_t": 8, "int64_t": 8, "uint64_t": 8, "double": 8, "mjtNum": 8,
}  # fmt: skip


class LayoutError(RuntimeError):
    """The struct layout of the installed MuJoCo could not be verified."""


def _size_align(t) -> tuple[int, int]:
    if isinstance(t, ast_nodes.PointerType):
        return 8, 8
    if isinstance(t, ast_nodes.ArrayType):
        size, align = _size_align(t.inner_type)
        return size * int(np.prod(t.extents)), align
    if isinstance(t, ast_nodes.AnonymousStructDecl):
        layout = _layout(t.fields)
        return layout["__size__"], layout["__align__"]
    if t.name in _PRIMITIVES:
        return _PRIMITIVES[t.name], _PRIMITIVES[t.name]
    if t.name in structs.STRUCTS:
        layout = _struct_layout(t.name)
        return layout["__size__"], layout["__align__"]
    if t.name in enums.ENUMS:
        return 4, 4
    raise LayoutError(f"unknown C type {t.name!r} in mujoco.introspect")


@functools.cache
def _struct_layout(name: str) -> dict[str, int]:
    return _layout(structs.STRUCTS[name].fields)


def _layout(fields) -> dict[str, int]:
    """Offsets of ``fields`` under the usual C alignment rules (x86-64 / aarch64 ABIs)."""
    offset, max_align, out = 0, 1, {}
    for f in fields:
        size, align = _size_align(f.type)
        offset = -(-offset // align) * align
        out[f.name] = offset
        offset += size
        max_align = max(max_align, align)
    out["__size__"] = -(-offset // max_align) * max_align
    out["__align__"] = max_align
    return out


def _read(address: int, ctype):
    return ctype.from_address(address).value


def _probe():
    spec = mujoco.MjSpec()
    body = spec.worldbody.add_body(name="probe")
    body.add_freejoint()
    body.add_geom(size=[0.1, 0, 0])
    body.add_site(name="s")
    model = spec.compile()
    return model, mujoco.MjData(model)


@functools.lru_cache(maxsize=1)
def verified_offsets() -> dict[str, int]:
    """Offsets (bytes) of ``DATA_POINTERS`` and ``time`` in mjData, and of ``disableflags``
    and ``timestep`` in mjModel; each checked against live objects."""
    data_layout = _struct_layout("mjData")
    model_layout = _struct_layout("mjModel")
    opt_layout = _struct_layout("mjOption")
    offsets = {name: data_layout[name] for name in (*DATA_POINTERS, "time")}
    offsets["disableflags"] = model_layout["opt"] + opt_layout["disableflags"]
    offsets["timestep"] = model_layout["opt"] + opt_layout["timestep"]

    model, data = _probe()
    mujoco.mj_forward(model, data)
    for name in DATA_POINTERS:
        got = _read(data._address + offsets[name], ctypes.c_uint64)
        if got != getattr(data, name).ctypes.data:
            raise LayoutError(f"mjData.{name} is not at byte offset {offsets[name]} in this MuJoCo build")
    for value in (0.125, 3.5):
        data.time = value
        if _read(data._address + offsets["time"], ctypes.c_double) != value:
            raise LayoutError("mjData.time is not where the layout says")
    for flags, step in ((0b1010, 0.0025), (0, 0.004)):
        model.opt.disableflags, model.opt.timestep = flags, step
        if (
            _read(model._address + offsets["disableflags"], ctypes.c_int) != flags
            or _read(model._address + offsets["timestep"], ctypes.c_double) != step
        ):
            raise LayoutError("mjModel.opt is not where the layout says")
    return offsets
