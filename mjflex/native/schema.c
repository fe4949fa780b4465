// The table of an element's attributes and the reading of a configuration by it (see schema.h).

#include "schema.h"

#include <ctype.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "flexure_math.h"
#include "json.h"

#define FIN MJFX_FINITE
#define BIG MJFX_MAX_MATRIX_ENTRY
#define ROT "[rx ry rz x y z] (planar: [theta x y])"

// clang-format off
const mjfxAttribute MJFX_SCHEMA[MJFX_NATTRIBUTE] = {
  {"site_a", NULL, MJFX_TYPE_NAME, MJFX_REQUIRED, 0, 0, 0, "", NULL, "a name", "",
   "the site of the element frame on body A (frame a). A text record has none: its sites are E/a and E/b (or E.a, "
   "E.b), found by the element's name E",
   "a site of the model, on another body than site_b; under MjSpec.attach read with the element's prefix and "
   "suffix. At qpos0 both sites coincide within 1e-5 times the site and body positions that place them "
   "(their rounding in saved files: the rest offset) and 1e-5 rad"},
  {"site_b", NULL, MJFX_TYPE_NAME, MJFX_REQUIRED, 0, 0, 0, "", NULL, "a name", "",
   "the site of the element frame on body B (frame b)", "as site_a"},
  {"method", "method", MJFX_TYPE_CHOICE, MJFX_WRITTEN, 0, 0, 0, "twist", "twist|dualquat", "a word", "",
   "how the relative displacement of frame b in frame a is measured: the finite twist, or the unit dual quaternion",
   "one of the words"},
  {"K", "K", MJFX_TYPE_MATRIX, MJFX_REQUIRED, 0, -BIG, BIG, "", NULL,
   "6 numbers (the diagonal) or 36 (a 6x6 matrix, row-major); 3 or 9 for a planar element [theta_z; x; y]",
   "N m/rad, N/rad, N/m",
   "stiffness in the element frame, rows [rotation; translation]",
   "finite, |entries| <= 1e280 (beyond, the energy overflows float64 for displacements MuJoCo accepts), "
   "symmetric (relative 1e-8) and positive semi-definite (relative 1e-10)"},
  {"B", "B", MJFX_TYPE_MATRIX, 0, 0, -BIG, BIG, "", NULL, "as K, of K's size", "N m s/rad, N s/m",
   "damping, the layout of K (default: none, purely elastic)", "as K"},
  {"enabled", "enabled", MJFX_TYPE_BOOL, 0, 0, 0, 0, "true", NULL, "a switch", "",
   "whether the element acts (a run-time switch of text records)", "true or false"},
  {"viscous", "viscous", MJFX_TYPE_BOOL, 0, 0, 0, 0, "true", NULL, "a switch", "",
   "whether the damping B acts (a run-time switch of text records)", "true or false"},
  {"strain_per_radian", "strain_per_radian", MJFX_TYPE_REAL, FIN | MJFX_DISPLAY, 0, 0, BIG, "", NULL, "1 number",
   "1/rad",
   "peak bending strain per radian of rotation about the frame's z axis, for reports and strain colours",
   ">= 0"},
  {"source", "source", MJFX_TYPE_JSON, 0, 0, 0, 0, "", NULL, "a JSON object", "",
   "where K came from (geometry, material, formula), kept verbatim",
   "standard JSON: double quotes, no NaN or Infinity, numbers within doubles"},
  {"exponents", "terms.exponents", MJFX_TYPE_INTS, 0, 0, 0, MJFX_MAX_EXPONENT, "", NULL,
   "rows of 6 (twist: tau t) or 8 (dualquat: sigma xi s' x') integers, one row per term", "",
   "the exponents of the polynomial terms added to K's energy (mjflex.core.polynomial), in the coordinates of "
   "method",
   "integers in [0, 16]; one row per coefficient; rows distinct; degrees from 2 to order, even for dualquat, and "
   "the dualquat terms unstressed at rest; K plus the terms' stiffness at rest positive semi-definite"},
  {"coefficients", "terms.coefficients", MJFX_TYPE_NUMBERS, FIN, 0, -HUGE_VAL, HUGE_VAL, "", NULL,
   "one number per row of exponents", "J", "the coefficients of the polynomial terms", "finite"},
  {"order", "order", MJFX_TYPE_INT, 0, 0, 2, MJFX_MAX_ORDER, "2", NULL, "1 integer", "",
   "order of the potential: the highest degree of its terms (2: the quadratic potential of K)",
   "even for dualquat; no term's degree above it"},
  {"site", "site", MJFX_TYPE_NAME, 0, 0, 0, 0, "", NULL, "a name", "",
   "the site that gives the element frame (add_flexure(..., site=...)), e.g. a robot's wrist_site",
   "a site of the model (read with the element's prefix under attach) that coincides with site_a at qpos0, "
   "within the sites' tolerances"},
  {"strain_scale", "strain_scale", MJFX_TYPE_REAL, FIN | MJFX_OPEN_LO | MJFX_DISPLAY, 0, 0, BIG, "", NULL,
   "1 number", "1, or rad",
   "full scale of the element's strain colour in MuJoCo's viewer: the strain drawn red (the rotation about z "
   "[rad] without strain_per_radian); default 0.01 (0.1 rad)", "> 0"},
  {"stop_lower", "stops.lower", MJFX_TYPE_LIMITS, 0, 0, -HUGE_VAL, 0, "", NULL, "one number per coordinate " ROT,
   "rad, m",
   "lower end stops: limits on the rotation vector and the position of frame b in frame a, -inf (record: "
   "null) where a coordinate has none",
   "not NaN; not +inf; rotation limits within [-pi, pi] (radians, not degrees); lower <= upper"},
  {"stop_upper", "stops.upper", MJFX_TYPE_LIMITS, 0, 0, HUGE_VAL, 0, "", NULL, "one number per coordinate " ROT,
   "rad, m", "upper end stops, inf (record: null) where a coordinate has none", "as stop_lower; not -inf"},
  {"stop_stiffness", "stops.stiffness", MJFX_TYPE_PER_COORD, FIN, 0, 0, BIG, "", NULL,
   "1 number (every coordinate) or one per coordinate", "N m/rad, N/m",
   "the stops' stiffness; default: derived, 100 K_ii of each coordinate",
   ">= 0; positive (given or derived, at most 1e280) on every coordinate with a limit; only with a limit"},
  {"stop_damping", "stops.damping", MJFX_TYPE_PER_COORD, FIN, 0, 0, BIG, "", NULL,
   "1 number (every coordinate) or one per coordinate", "N m s/rad, N s/m",
   "the stops' damping, on the stop coordinates' rates beyond a limit only; a stop's force is clamped at 0, so it "
   "never pulls the body back in, and its loss counts in the dissipated power (default: none, conservative stops)",
   ">= 0; only with a limit"},
  {"rest_pos", "rest.pos", MJFX_TYPE_VECTOR, FIN, 3, -mjMAXVAL, mjMAXVAL, "", NULL, "3 numbers", "m",
   "the rest pose's position: frame b in frame a where the element's energy is zero (default: 0 0 0). Energies, "
   "wrenches and stop coordinates count from the rest pose; one the model does not hold preloads the element",
   "finite, |x| <= 1e10 (MuJoCo's largest position, mjMAXVAL: with K's bound, the forces stay finite)"},
  {"rest_quat", "rest.quat", MJFX_TYPE_VECTOR, FIN, 4, -BIG, BIG, "", NULL, "4 numbers, w x y z", "",
   "the rest pose's orientation, a unit quaternion (default: 1 0 0 0). The rest pose is composed into the rest "
   "offset after the sites' rounding residual",
   "finite; norm 1 within 1e-6 (then normalized)"},
};
// clang-format on

const char* const MJFX_COORDINATES[2][6] = {{"rx", "ry", "rz", "x", "y", "z"}, {"theta", "x", "y"}};
const char* const MJFX_COORDINATE_LIST[2] = {"[rx ry rz x y z]", "[theta x y]"};

void mjfx_element_head(const char* name, int form, char* out, int size) {
  if (form == MJFX_FORM_RECORD) {
    snprintf(out, size, "flexure '%.200s': ", name);
  } else if (form == MJFX_FORM_PLUGIN) {
    snprintf(out, size, "mjflex: flexure '%.200s' (plugin instance of %s): ", name, MJFX_PLUGIN_NAME);
  } else {
    snprintf(out, size, "%s", "");
  }
}

const char* mjfx_key(int row, int form) {
  const mjfxAttribute* a = MJFX_SCHEMA + row;
  return form != MJFX_FORM_PLUGIN && a->json ? a->json : a->key;
}

int mjfx_fail(char* err, int errsz, const char* head, const char* fmt, ...) {
  int len = snprintf(err, errsz, "%s", head);
  if (len >= 0 && len < errsz) {
    va_list args;
    va_start(args, fmt);
    vsnprintf(err + len, errsz - len, fmt, args);
    va_end(args);
  }
  return -1;
}

//------------------------------------------------------------------------------ the grammar

static int is_space(char c) {
  return isspace((unsigned char)c);
}

// the token at s (up to white space) quoted into out, shortened to fit
static void token_text(const char* s, char* out, int size) {
  int i = 0;
  while (s[i] && !is_space(s[i]) && i < size - 1 && i < 40) out[i] = s[i], i++;
  out[i] = 0;
  if (s[i] && !is_space(s[i])) snprintf(out + (i > size - 4 ? size - 4 : i), 4, "...");
}

// One number: what strtod reads (decimal or hexadecimal, inf, nan), up to white space; 0 or -1.
static int read_number(const char** s, double* out) {
  char* end;
  *out = strtod(*s, &end);
  if (end == *s || (*end && !is_space(*end))) return -1;
  *s = end;
  return 0;
}

// One integer: an optional sign and at most 9 digits, up to white space; 0 or -1.
static int read_int(const char** s, double* out) {
  const char* p = *s + (**s == '+' || **s == '-');
  const char* digits = p;
  while (isdigit((unsigned char)*p)) p++;
  if (p == digits || (*p && !is_space(*p)) || p - digits > 9) return -1;
  *out = (double)strtol(*s, NULL, 10);
  *s = p;
  return 0;
}

int mjfx_values_set(mjfxValues* v, int row, const double* x, int n) {
  if (v->nnum + n > v->cap) {
    int cap = 2 * (v->nnum + n) + 16;
    double* num = realloc(v->num, sizeof(double) * cap);
    if (!num) return -1;
    v->num = num, v->cap = cap;
  }
  if (n) memcpy(v->num + v->nnum, x, sizeof(double) * n);
  v->count[row] = n, v->first[row] = v->nnum;
  v->nnum += n;
  return 0;
}

void mjfx_free_values(mjfxValues* v) {
  free(v->num);
  memset(v, 0, sizeof(mjfxValues));
}

// the numbers (integers) of text into v as row's value; -1 with the message for a token that is not one
static int read_list(const char* head, int form, int row, const char* text, int integers, mjfxValues* v, char* err,
                     int errsz) {
  int n = 0, start = v->nnum;
  for (const char* s = text; *s;) {
    while (is_space(*s)) s++;
    if (!*s) break;
    double x;
    if (integers ? read_int(&s, &x) : read_number(&s, &x)) {
      char bad[48];
      token_text(s, bad, sizeof(bad));
      const char* key = mjfx_key(row, form);
      return mjfx_fail(err, errsz, head, "%s has '%s', which is not %s. Write %s as %s separated by spaces", key, bad,
                       integers ? "an integer" : "a number", key, integers ? "integers" : "numbers");
    }
    if (mjfx_values_set(v, row, &x, 1)) return mjfx_fail(err, errsz, head, "out of memory");
    n++;
  }
  v->count[row] = n, v->first[row] = start;
  return 0;
}

// the coordinates of the element (from K's size; with none, from `count` numbers), for messages
static int planar_of(const mjfxValues* v, int count) {
  int k = v->count[MJFX_A_K];
  return k >= 0 ? (k == 3 || k == 9) : count == 3;
}

// "at least 0", "above 0"
static void bound_text(const mjfxAttribute* a, char* out, int size) {
  if (a->lo == -a->hi) {
    snprintf(out, size, isinf(a->hi) ? "finite numbers" : "finite numbers (|x| <= %g)", a->hi);
  } else {
    snprintf(out, size, "a finite number %s %g (at most %g)", a->flags & MJFX_OPEN_LO ? ">" : ">=", a->lo, a->hi);
  }
}

static int out_of_bounds(const mjfxAttribute* a, double x) {
  return !isfinite(x) || x > a->hi || (a->flags & MJFX_OPEN_LO ? !(x > a->lo) : !(x >= a->lo));
}

// The counts and bounds of row's value (the table's own checks; those across attributes are config.c's).
static int check_row(const char* head, int form, int row, const char* text, const mjfxValues* v, char* err,
                     int errsz) {
  const mjfxAttribute* a = MJFX_SCHEMA + row;
  const char* key = mjfx_key(row, form);
  int count = v->count[row];
  const double* x = v->num + v->first[row];
  char bounds[96];
  bound_text(a, bounds, sizeof(bounds));
  switch (a->type) {
    case MJFX_TYPE_REAL:
      if (count != 1 || out_of_bounds(a, x[0])) {
        return mjfx_fail(err, errsz, head, "%s must be %s; got '%.40s'", key, bounds, text);
      }
      return 0;
    case MJFX_TYPE_INT:
      if (count != 1 || x[0] < a->lo || x[0] > a->hi) {
        return mjfx_fail(err, errsz, head, "%s must be one integer from %g to %g; got '%.40s'", key, a->lo, a->hi,
                         text);
      }
      return 0;
    case MJFX_TYPE_VECTOR:
      if (count != a->count) {
        return mjfx_fail(err, errsz, head, "%s has %d numbers; give %d: %s", key, count, a->count, a->meaning);
      }
      break;
    case MJFX_TYPE_PER_COORD: {
      int planar = planar_of(v, count), n = planar ? 3 : 6;
      const char* const* names = MJFX_COORDINATES[planar];
      if (count != 1 && count != n) {
        return mjfx_fail(err, errsz, head, "%s has %d numbers; give 1 (every coordinate) or %d (one per coordinate "
                         "%s) [%s]", key, count, n, MJFX_COORDINATE_LIST[planar], a->units);
      }
      for (int i = 0; i < count; i++) {
        if (out_of_bounds(a, x[i])) {
          return mjfx_fail(err, errsz, head, "%s of %s is %g; give %s [%s]", key, count == 1 ? "every coordinate"
                           : names[i], x[i], bounds, a->units);
        }
      }
      return 0;
    }
    case MJFX_TYPE_INTS:
      for (int i = 0; i < count; i++) {
        if (x[i] < a->lo || x[i] > a->hi) {
          return mjfx_fail(err, errsz, head, "%s has %g (number %d): give integers in [%g, %g]", key, x[i], i, a->lo,
                           a->hi);
        }
      }
      return 0;
    default:
      return 0;
  }
  for (int i = 0; i < count && (a->flags & MJFX_FINITE); i++) {  // vectors, numbers
    if (out_of_bounds(a, x[i])) {
      return mjfx_fail(err, errsz, head, "%s has %g (number %d); give %s", key, x[i], i, bounds);
    }
  }
  return 0;
}

// The words of a choice: the index of text's among them, or -1.
static int choice_index(const char* choices, const char* text, size_t len) {
  int k = 0;
  for (const char* c = choices; *c; k++) {
    size_t n = strcspn(c, "|");
    if (n == len && !strncmp(c, text, len)) return k;
    c += n + (c[n] == '|');
  }
  return -1;
}

int mjfx_read_values(const char* head, int form, const char* const* values, int partial, mjfxValues* v, char* err,
                     int errsz) {
  memset(v, 0, sizeof(mjfxValues));
  for (int row = 0; row < MJFX_NATTRIBUTE; row++) {
    const mjfxAttribute* a = MJFX_SCHEMA + row;
    const char* key = mjfx_key(row, form);
    const char* text = values[row];
    while (is_space(*text)) text++;
    size_t len = strlen(text);
    while (len && is_space(text[len - 1])) len--;
    v->count[row] = -1;
    if (!len) {
      if ((a->flags & MJFX_REQUIRED) && !partial && a->type != MJFX_TYPE_NAME) {  // names: the reader of sites
        mjfx_fail(err, errsz, head, "%s is missing: give %s [%s]", key, a->shape, a->units);
        mjfx_free_values(v);
        return -1;
      }
      continue;
    }
    int rc = 0;
    double x;
    switch (a->type) {
      case MJFX_TYPE_NAME:
      case MJFX_TYPE_JSON:
        if (a->type == MJFX_TYPE_JSON && !mjfx_json_object(text)) {
          rc = mjfx_fail(err, errsz, head, "%s must be one JSON object, such as {\"formula\": \"...\"} (%s); got "
                         "'%.60s'", key, a->rules, text);
        }
        v->count[row] = (int)len, v->first[row] = (int)(text - values[row]);
        break;
      case MJFX_TYPE_CHOICE:
      case MJFX_TYPE_BOOL: {
        int k = choice_index(a->type == MJFX_TYPE_BOOL ? "false|true" : a->choices, text, len);
        if (k < 0) {
          rc = a->type == MJFX_TYPE_BOOL
                   ? mjfx_fail(err, errsz, head, "%s must be true or false; got '%.40s'", key, text)
                   : mjfx_fail(err, errsz, head, "unknown %s '%.40s'. Use %s \"%.*s\" or \"%s\"", key, text, key,
                               (int)strcspn(a->choices, "|"), a->choices, strchr(a->choices, '|') + 1);
        } else {
          x = k;
          rc = mjfx_values_set(v, row, &x, 1) ? mjfx_fail(err, errsz, head, "out of memory") : 0;
        }
        break;
      }
      default:
        rc = read_list(head, form, row, text, a->type == MJFX_TYPE_INT || a->type == MJFX_TYPE_INTS, v, err, errsz);
        if (!rc) rc = check_row(head, form, row, text, v, err, errsz);
    }
    if (rc) {
      mjfx_free_values(v);
      return -1;
    }
  }
  return 0;
}

double mjfx_config_number(const mjModel* m, int instance, int row, double fallback) {
  const char* text = mj_getPluginConfig(m, instance, MJFX_SCHEMA[row].key);
  double x;
  if (!text) return fallback;
  while (is_space(*text)) text++;
  return *text && !read_number(&text, &x) ? x : fallback;
}

//------------------------------------------------------------------------------ for Python

const char* mjfx_schema_text(int i, const char* field) {
  if (i < 0 || i >= MJFX_NATTRIBUTE || !field) return NULL;
  const mjfxAttribute* a = MJFX_SCHEMA + i;
  const char* fields[][2] = {{"key", a->key}, {"json", a->json ? a->json : ""}, {"choices", a->choices ? a->choices : ""},
                             {"fallback", a->fallback}, {"shape", a->shape}, {"units", a->units},
                             {"meaning", a->meaning}, {"rules", a->rules}};
  for (size_t k = 0; k < sizeof(fields) / sizeof(fields[0]); k++) {
    if (!strcmp(fields[k][0], field)) return fields[k][1];
  }
  return NULL;
}

double mjfx_schema_number(int i, const char* field) {
  if (i < 0 || i >= MJFX_NATTRIBUTE || !field) return NAN;
  const mjfxAttribute* a = MJFX_SCHEMA + i;
  if (!strcmp(field, "type")) return a->type;
  if (!strcmp(field, "flags")) return a->flags;
  if (!strcmp(field, "count")) return a->count;
  if (!strcmp(field, "lo")) return a->lo;
  if (!strcmp(field, "hi")) return a->hi;
  return NAN;
}
