// The attributes of an element: one table (MJFX_SCHEMA, schema.c) says, for each, its name in both forms (the
// engine plugin's <config> key and the text record's JSON key), its type and shape, default, units, meaning and
// checks. Everything else follows from it: the reading of a configuration here (the one grammar of numbers,
// integers, switches and words, and each number's bounds), the element's cross-attribute checks (config.c), the
// messages (in the words of the element's form), Python's converters between the forms (mjflex/mjcf/schema.py
// reads the table through ctypes) and the schema page (docs/reference/mjcf_schema.md, generated from the table).

#ifndef MJFLEX_NATIVE_SCHEMA_H_
#define MJFLEX_NATIVE_SCHEMA_H_

#include <mujoco/mujoco.h>

#define MJFX_PLUGIN_NAME "mjflex.flexure"

// Limits that the table's bounds use (tests/test_native_constants.py holds Python's equal).
#define MJFX_MAX_MATRIX_ENTRY 1e280  // largest |entry| of K, B and of the stops' stiffness and damping
#define MJFX_MAX_TERMS 100000
#define MJFX_MAX_ORDER 128  // the highest order of a potential: every variable at its highest exponent (8 x 16)
// largest |rotation limit| of a stop [rad]: pi, and the round-off of pi written in any way
#define MJFX_PI_TOLERANT (3.141592653589793 * (1.0 + 1e-12))

// The types of attribute values. Config text: numbers and integers separated by white space; white space around
// any value is not part of it. Record JSON: in brackets.
#define MJFX_TYPE_NAME 0       // a name (a JSON string)
#define MJFX_TYPE_CHOICE 1     // one of the words in `choices` (a JSON string)
#define MJFX_TYPE_BOOL 2       // true or false (JSON true, false)
#define MJFX_TYPE_INT 3        // one integer (a JSON integer)
#define MJFX_TYPE_REAL 4       // one number (a JSON number)
#define MJFX_TYPE_MATRIX 5     // a square matrix: its diagonal, or every entry row-major (a list, or a list of rows)
#define MJFX_TYPE_VECTOR 6     // `count` numbers (a list)
#define MJFX_TYPE_LIMITS 7     // one limit per coordinate, -inf / inf where none (a list, null where none)
#define MJFX_TYPE_PER_COORD 8  // one number for every coordinate, or one per coordinate (a number, or a list)
#define MJFX_TYPE_INTS 9       // integers, in rows of the method's coordinates (a list of rows)
#define MJFX_TYPE_NUMBERS 10   // numbers (a list)
#define MJFX_TYPE_JSON 11      // a JSON object (RFC 8259: no NaN or Infinity), kept verbatim (an object)

// Flags of an attribute.
#define MJFX_REQUIRED 1  // must be given
#define MJFX_WRITTEN 2   // mjflex's writers write it even at its default
#define MJFX_DISPLAY 4   // for the drawing and reports only: never read by the forces
#define MJFX_OPEN_LO 16  // numbers must be above lo (else at least lo)
#define MJFX_FINITE 32   // numbers must be finite (and within lo, hi)

typedef struct mjfxAttribute_ {
  const char* key;      // the plugin's <config> key
  const char* json;     // the record's JSON key ("stops.lower": key "lower" of object "stops"); NULL: none
  int type;             // MJFX_TYPE_*
  int flags;            // MJFX_REQUIRED | ...
  int count;            // how many numbers (MJFX_TYPE_VECTOR), else 0
  double lo, hi;        // bounds of each number (with MJFX_FINITE), or of the integer; limits: lo is the limit of a
                        // coordinate without a stop
  const char* fallback; // the default, as config text ("" none)
  const char* choices;  // MJFX_TYPE_CHOICE: the words, separated by '|'
  const char* shape;    // its shape in words
  const char* units;    // its units
  const char* meaning;  // what it means
  const char* rules;    // its checks, in words (the cross-attribute ones, in config.c, too)
} mjfxAttribute;

// The rows of MJFX_SCHEMA, in the order MuJoCo stores an instance's values (and the record's fields).
enum {
  MJFX_A_SITE_A, MJFX_A_SITE_B, MJFX_A_METHOD, MJFX_A_K, MJFX_A_B, MJFX_A_ENABLED, MJFX_A_VISCOUS, MJFX_A_STRAIN,
  MJFX_A_SOURCE, MJFX_A_EXPONENTS, MJFX_A_COEFFICIENTS, MJFX_A_ORDER, MJFX_A_SITE, MJFX_A_STRAIN_SCALE,
  MJFX_A_STOP_LOWER, MJFX_A_STOP_UPPER, MJFX_A_STOP_STIFFNESS, MJFX_A_STOP_DAMPING, MJFX_A_REST_POS,
  MJFX_A_REST_QUAT, MJFX_NATTRIBUTE
};
extern const mjfxAttribute MJFX_SCHEMA[MJFX_NATTRIBUTE];

// The coordinates of an element's stops, spatial [0] and planar [1]: their names, and as one list.
extern const char* const MJFX_COORDINATES[2][6];
extern const char* const MJFX_COORDINATE_LIST[2];

// The two forms an element is written in, for its messages: an instance of the engine plugin (its
// <config> attributes) or a text record mjflex:E (sites E/a and E/b; mjflex's Python layer reads its
// JSON and gives C the same configuration strings); and a third, arguments (mjflex.Stops), without an element.
#define MJFX_FORM_PLUGIN 0
#define MJFX_FORM_RECORD 1
#define MJFX_FORM_ARGUMENTS 2

// The head of every message about element `name` written in `form` (MJFX_FORM_*):
// "mjflex: flexure 'E' (plugin instance of mjflex.flexure): ", "flexure 'E': " or "".
void mjfx_element_head(const char* name, int form, char* out, int size);

// The name of attribute `row` in the words of `form`: its <config> key, or its JSON key (record, arguments).
const char* mjfx_key(int row, int form);

// Message: head and the problem (printf); returns -1.
int mjfx_fail(char* err, int errsz, const char* head, const char* fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;

// A configuration read by the table: for each attribute, how many numbers it has and where they start in num
// (the numbers of a switch are 0 / 1, of a word its index in `choices`), or for a name and a JSON object the
// length and offset of its value within its string (white space around it left out); count -1: not given.
// Matrices are stored as given (mjfx_values_matrix expands them).
typedef struct mjfxValues_ {
  int count[MJFX_NATTRIBUTE];
  int first[MJFX_NATTRIBUTE];
  double* num;
  int nnum, cap;
} mjfxValues;

// Read configuration strings values[MJFX_NATTRIBUTE] (MJFX_SCHEMA order) by the table: each value's grammar
// (numbers, integers, switches, words, JSON) and each number's bounds; a missing required attribute is an error
// unless `partial`. 0, or -1 with the message in err (head: mjfx_element_head; v holds nothing then).
int mjfx_read_values(const char* head, int form, const char* const* values, int partial, mjfxValues* v, char* err,
                     int errsz);
void mjfx_free_values(mjfxValues* v);

// Append n numbers to v as attribute row's value (count, first); 0 or -1 (out of memory).
int mjfx_values_set(mjfxValues* v, int row, const double* x, int n);

// The first number of a (checked) value of plugin instance `instance` of m, or fallback when it is not given:
// what the drawing reads of its display attributes.
double mjfx_config_number(const mjModel* m, int instance, int row, double fallback);

// The table for Python (ctypes): text field `field` of row i (key, json, choices, fallback, shape, units,
// meaning, rules; NULL for a row out of range or an unknown field), and number field `field` (type, flags,
// count, lo, hi; NaN for none).
const char* mjfx_schema_text(int i, const char* field);
double mjfx_schema_number(int i, const char* field);

#endif  // MJFLEX_NATIVE_SCHEMA_H_
