// The MJCF configuration of an element: parsed and validated once, in the plugin's init for an
// instance (a failure is a model compile error naming the element and the fix) and when mjflex's
// Python layer reads a text record (given as the same strings).
// The attributes and their rules are documented in mjflex/mjcf/schema.py (PLUGIN_ATTRIBUTES),
// beside the text record they mirror; the rules are the record's. tests/test_native_constants.py
// holds the constants below equal to Python's (mjfx_constant).

#ifndef MJFLEX_NATIVE_CONFIG_H_
#define MJFLEX_NATIVE_CONFIG_H_

#include <mujoco/mujoco.h>

#include "elements.h"

#define MJFX_PLUGIN_NAME "mjflex.flexure"
#define MJFX_NATTRIBUTE 20
extern const char* const MJFX_ATTRIBUTES[MJFX_NATTRIBUTE];

// Validation constants (mjflex.mjcf.schema, mjflex.core.validation, mjflex.core.polynomial).
#define MJFX_MAX_MATRIX_ENTRY 1e280
#define MJFX_SYMMETRY_RTOL 1e-8
#define MJFX_PSD_RTOL 1e-10
#define MJFX_COINCIDENCE_RTOL 1e-5
#define MJFX_COINCIDENCE_ANGLE 1e-5
#define MJFX_REST_STRESS_RTOL 1e-12
#define MJFX_MAX_TERMS 100000
// largest |norm - 1| of an element's rest_quat (mjflex.core.rest.REST_QUAT_TOLERANCE): a quaternion written with
// 7 significant digits passes, one that is not a rotation does not
#define MJFX_REST_QUAT_TOL 1e-6
// derived stiffness of an end stop: this times K_ii (mjflex.core.stops.STIFFNESS_FACTOR)
#define MJFX_STOP_STIFFNESS_FACTOR 100.0
// largest |rotation limit| of a stop [rad] (mjflex.mjcf.stops.MAX_ROTATION_LIMIT): pi, and the round-off of pi
// written in any way
#define MJFX_PI_TOLERANT (3.141592653589793 * (1.0 + 1e-12))

// A parsed element: its table row and its own terms (exps: MJFX_TERM_COLUMNS per row), and what the
// plugin's visualize callback needs: strain per radian and the colour scale's full scale (0: not given).
typedef struct mjfxParsed_ {
  mjfxElement el;
  int* exps;
  double* coefs;
  int nterms;
  int planar;
  double strain_per_radian;
  double strain_scale;
  int has_rest;           // a rest pose is given (rest_pos, rest_quat; the other part: identity)
  double rest_pos[3];     // the rest pose: position [m] and unit quaternion (normalized) of frame b in frame a
  double rest_quat[4];
} mjfxParsed;

// Full scale of the strain colours when an element gives none (mjflex.mjcf.schema.DEFAULT_STRAIN_SCALE):
// 1 % strain with strain_per_radian, else 0.1 rad of rotation about the element's z axis.
#define MJFX_DEFAULT_STRAIN_SCALE 0.01
#define MJFX_DEFAULT_ROTATION_SCALE 0.1

// The two forms an element is written in, for its messages: an instance of the engine plugin (its
// <config> attributes) or a text record mjflex:E (sites E/a and E/b; mjflex's Python layer reads its
// JSON and gives C the same configuration strings: mjflex.mjcf.config.config_from_record).
#define MJFX_FORM_PLUGIN 0
#define MJFX_FORM_RECORD 1

// The head of every message about element `name` written in `form` (MJFX_FORM_*):
// "mjflex: flexure 'E' (plugin instance of mjflex.flexure): " or "flexure 'E': ".
void mjfx_element_head(const char* name, int form, char* out, int size);

// Parse the configuration strings values[MJFX_NATTRIBUTE] (in MJFX_ATTRIBUTES order) of
// element `name` into out (site, body and offset fields are not touched; the rest pose is left in
// out->rest_pos/rest_quat for the reader to compose into the offset, mjfx_compose_rest). Returns 0, or -1
// with a message in err that names the element (in the words of its form), the problem and the
// fix; out->exps and out->coefs are allocated (malloc) only on success.
int mjfx_parse_config(const char* name, int form, const char* const* values, mjfxParsed* out, char* err,
                      int errsz);

// Check that a 6x6 matrix (or 3x3 when n == 3) is finite, within MJFX_MAX_MATRIX_ENTRY,
// symmetric and positive semi-definite; returns 0 or -1 with the problem in err.
int mjfx_check_matrix(const double* M, int n, const char* key, int stiffness, char* err, int errsz);

// Smallest eigenvalue of a symmetric n x n matrix (n <= 6), by Jacobi rotations.
double mjfx_min_eigenvalue(const double* M, int n);

// Whether text is one complete JSON object (RFC 8259; no NaN or Infinity).
int mjfx_json_object(const char* text);

#endif  // MJFLEX_NATIVE_CONFIG_H_
