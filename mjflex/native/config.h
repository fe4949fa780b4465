// The configuration of an element: read by the attribute table (schema.h) and checked across its attributes,
// once, in the plugin's init for an instance (a failure is a model compile error naming the element and the fix),
// when mjflex's Python layer reads a text record (given as the same strings), and for Python's converters
// (mjfx_parse_values). tests/test_native_constants.py holds the constants below equal to Python's (mjfx_constant).

#ifndef MJFLEX_NATIVE_CONFIG_H_
#define MJFLEX_NATIVE_CONFIG_H_

#include "elements.h"
#include "schema.h"

// Tolerances of the checks (mjflex.mjcf.schema, mjflex.core.polynomial; the matrices' are matrix.h's).
#define MJFX_COINCIDENCE_RTOL 1e-5
#define MJFX_COINCIDENCE_ANGLE 1e-5
// largest |norm - 1| of an element's rest_quat (mjflex.core.rest.REST_QUAT_TOLERANCE): a quaternion written with
// 7 significant digits passes, one that is not a rotation does not
#define MJFX_REST_QUAT_TOL 1e-6
// derived stiffness of an end stop: this times K_ii (mjflex.core.stops.STIFFNESS_FACTOR)
#define MJFX_STOP_STIFFNESS_FACTOR 100.0
// Full scale of the strain colours when an element gives none (the drawing's): 1 % strain with
// strain_per_radian, else 0.1 rad of rotation about the element's z axis.
#define MJFX_DEFAULT_STRAIN_SCALE 0.01
#define MJFX_DEFAULT_ROTATION_SCALE 0.1

// A parsed element: its table row, its own terms (exps: MJFX_TERM_COLUMNS per row), its rest pose, and the values
// read (for Python).
typedef struct mjfxParsed_ {
  mjfxElement el;
  int* exps;
  double* coefs;
  int nterms;
  int planar;
  int has_rest;          // a rest pose is given (rest_pos, rest_quat; the other part: identity)
  double rest_pos[3];    // the rest pose: position [m] and unit quaternion (normalized) of frame b in frame a
  double rest_quat[4];
  mjfxValues values;
} mjfxParsed;

// Parse the configuration strings values[MJFX_NATTRIBUTE] (MJFX_SCHEMA order) of element `name` written in `form`
// (MJFX_FORM_*) into out (site, body and offset fields are not touched): the table's checks, then those across
// attributes. MJFX_FORM_ARGUMENTS checks what is given without an element (no K: the stops' own rules). Returns
// 0, or -1 with a message in err that names the element (in the words of its form), the problem and the fix;
// out holds allocations only on success (mjfx_free_parsed).
int mjfx_parse_config(const char* name, int form, const char* const* values, mjfxParsed* out, char* err,
                      int errsz);
void mjfx_free_parsed(mjfxParsed* p);

#endif  // MJFLEX_NATIVE_CONFIG_H_
