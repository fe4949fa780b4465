"""Compare generated text (MJCF model files, JSON records) by what matters: structure exactly, numbers to a tolerance.

A file written by a generator is reproducible only up to the last bit of the numerical libraries that computed its
numbers: numpy, scipy and numba pick SIMD code paths by CPU, and their versions change rounding (the committed
``models/arcade.xml`` differs from a regeneration on a CPU without AVX-512 in 36 of 4894 numbers, by 1 ulp). So:

* XML is parsed, and elements (tags, order, nesting), attribute names (and their order) and every piece of text that
  is not a number must be equal;
* numbers are found generically in any attribute value or text (space-separated lists, JSON records in text or
  CDATA, ``config value="..."`` lists alike): a token that parses as a float, delimited by anything but a letter,
  digit, ``_`` or ``.``; names such as ``leaf_p0_L1`` or versions such as ``4.0.0`` stay text and compare exactly;
* two numbers agree when ``|a - b| <= rtol max(|a|, |b|) + atol_scale * scale``, where ``scale`` is the largest
  magnitude of the numbers they are listed with (one ``[...]`` list of a JSON record, or one attribute value; a
  number elsewhere stands alone). See :data:`RTOL` and :data:`ATOL_SCALE` for why these values.
"""

import math
import re
import xml.etree.ElementTree as ET

#: Relative tolerance. The generator's numbers come from short computations: stiffness tables interpolated by
#: splines in log space, then ``exp`` and a three-point Lagrange sum; products of geometry; rotations through
#: trigonometric functions. Their condition is at most ~1e3, so a few ulps (eps = 2.2e-16) of difference between
#: SIMD code paths or library versions move them by at most ~1e-13 relative (1 ulp is what was observed); 1e-12
#: leaves a margin and still catches any change of the model itself: its inputs are given to 4-6 digits.
RTOL = 1e-12
#: Absolute tolerance relative to the largest number of the same list: an entry that is small by cancellation (an
#: off-diagonal of a rotated stiffness, a quaternion component that should be 0) is accurate only to some ulps of
#: the largest terms it was computed from; 1e-14 is ~50 ulps of those.
ATOL_SCALE = 1e-14

_NUMBER = re.compile(
    r"(?<![\w.+-])[-+]?(?:(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?|nan|inf(?:inity)?)(?![\w.])", re.IGNORECASE
)


def split_numbers(text, *, one_list=False):
    """``(parts, numbers, groups)`` of ``text``: the text between numbers, the numbers' strings, their list ids.

    ``len(parts) == len(numbers) + 1``. Numbers inside one ``[...]`` share a group id; with ``one_list`` (an
    attribute value) every number outside brackets is in group 0, else each such number is a group of its own.
    """
    parts, numbers, groups = [], [], []
    stack, next_id, pos = [], 1, 0
    for match in _NUMBER.finditer(text):
        between = text[pos : match.start()]
        for ch in between:
            if ch == "[":
                stack.append(next_id)
                next_id += 1
            elif ch == "]" and stack:
                stack.pop()
        parts.append(between)
        numbers.append(match.group())
        if stack:
            groups.append(stack[-1])
        elif one_list:
            groups.append(0)
        else:
            groups.append(next_id)
            next_id += 1
        pos = match.end()
    parts.append(text[pos:])
    return parts, numbers, groups


class Report:
    """What a comparison looked at: ``numbers`` compared, ``worst`` relative difference, ``problems`` found."""

    def __init__(self):
        self.numbers, self.worst, self.problems = 0, 0.0, []

    def fail(self, where, what):
        self.problems.append(f"{where}: {what}")


def _compare_text(actual, expected, where, report, rtol, atol_scale, one_list):
    actual, expected = actual or "", expected or ""
    pa, na, ga = split_numbers(actual, one_list=one_list)
    pe, ne, ge = split_numbers(expected, one_list=one_list)
    if pa != pe or ga != ge:
        report.fail(where, f"text differs beyond its numbers: {_short(actual)!r} vs expected {_short(expected)!r}")
        return
    xa, xe = [float(x) for x in na], [float(x) for x in ne]
    scale = {}
    for g, a, e in zip(ge, xa, xe, strict=True):
        scale[g] = max(scale.get(g, 0.0), abs(a) if math.isfinite(a) else 0.0, abs(e) if math.isfinite(e) else 0.0)
    for k, (g, a, e) in enumerate(zip(ge, xa, xe, strict=True)):
        report.numbers += 1
        if a == e or (math.isnan(a) and math.isnan(e)):
            continue
        if not (math.isfinite(a) and math.isfinite(e)):
            report.fail(where, f"number {k} is {na[k]}, expected {ne[k]}")
            continue
        diff = abs(a - e)
        if diff <= rtol * max(abs(a), abs(e)) + atol_scale * scale[g]:
            report.worst = max(report.worst, diff / max(abs(a), abs(e)))
            continue
        report.fail(
            where, f"number {k} is {na[k]}, expected {ne[k]} (relative difference {diff / max(abs(e), 1e-300):.3g})"
        )


def _short(text, n=120):
    return text if len(text) <= n else text[: n // 2] + " ... " + text[-n // 2 :]


def _compare_elements(a, e, parent, index, report, rtol, atol_scale):
    name = e.get("name")
    here = f"{parent}/{e.tag}" + (f"[{name}]" if name is not None else f"[{index}]" if index is not None else "")
    if a.tag != e.tag:
        report.fail(here, f"element <{a.tag}> where <{e.tag}> was expected")
        return
    if list(a.attrib) != list(e.attrib):
        report.fail(here, f"attributes {list(a.attrib)}, expected {list(e.attrib)}")
    for key in e.attrib:
        if key in a.attrib:
            _compare_text(a.get(key), e.get(key), f"{here}@{key}", report, rtol, atol_scale, one_list=True)
    _compare_text((a.text or "").strip(), (e.text or "").strip(), f"{here} text", report, rtol, atol_scale, False)
    ca, ce = list(a), list(e)
    tags_a, tags_e = [c.tag for c in ca], [c.tag for c in ce]
    if tags_a != tags_e:
        i = next((i for i, (x, y) in enumerate(zip(tags_a, tags_e, strict=False)) if x != y), min(len(ca), len(ce)))
        got, wanted = (f"<{t[i]}>" if i < len(t) else "nothing" for t in (tags_a, tags_e))
        report.fail(here, f"child {i} is {got} where {wanted} was expected ({len(ca)} children, expected {len(ce)})")
        return
    for i, (x, y) in enumerate(zip(ca, ce, strict=True)):
        _compare_elements(x, y, here, i, report, rtol, atol_scale)
        _compare_text((x.tail or "").strip(), (y.tail or "").strip(), f"{here} text after child {i}", report, rtol,
                      atol_scale, False)  # fmt: skip


def compare_xml(actual, expected, *, rtol=RTOL, atol_scale=ATOL_SCALE):
    """Compare two XML documents (strings): structure exactly, numbers to the tolerance; returns a :class:`Report`.

    Whitespace around element text is ignored (indentation); everything else that is not a number is compared
    exactly.
    """
    report = Report()
    _compare_elements(ET.fromstring(actual), ET.fromstring(expected), "", None, report, rtol, atol_scale)
    return report


def compare_text(actual, expected, *, rtol=RTOL, atol_scale=ATOL_SCALE):
    """Compare two texts (e.g. JSON): everything but the numbers exactly, numbers to the tolerance."""
    report = Report()
    _compare_text(actual, expected, "text", report, rtol, atol_scale, one_list=False)
    return report


def assert_xml_equivalent(actual, expected, *, rtol=RTOL, atol_scale=ATOL_SCALE, hint=""):
    """Assert :func:`compare_xml` finds no difference; the message lists the first ones (and ``hint``)."""
    report = compare_xml(actual, expected, rtol=rtol, atol_scale=atol_scale)
    if report.problems:
        shown = "\n  ".join(report.problems[:8])
        more = f"\n  ... and {len(report.problems) - 8} more" if len(report.problems) > 8 else ""
        raise AssertionError(f"{len(report.problems)} difference(s){'; ' + hint if hint else ''}:\n  {shown}{more}")
    return report
