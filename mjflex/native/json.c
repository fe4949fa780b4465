// A validator of JSON objects (see json.h): no values are kept, nesting at most 200 deep, numbers within doubles.

#include "json.h"

#include <ctype.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct {
  const char* s;
  int depth;
} Json;

static int json_value(Json* j);

static void json_space(Json* j) {
  while (*j->s == ' ' || *j->s == '\t' || *j->s == '\n' || *j->s == '\r') j->s++;
}

static int json_string(Json* j) {
  if (*j->s != '"') return 0;
  for (j->s++; *j->s != '"'; j->s++) {
    unsigned char c = (unsigned char)*j->s;
    if (c < 0x20) return 0;
    if (c == '\\') {
      j->s++;
      if (*j->s == 'u') {
        for (int k = 1; k <= 4; k++) {
          if (!isxdigit((unsigned char)j->s[k])) return 0;
        }
        j->s += 4;
      } else if (!strchr("\"\\/bfnrt", *j->s) || !*j->s) {
        return 0;
      }
    }
  }
  j->s++;
  return 1;
}

static int json_number(Json* j) {
  const char* s = j->s;
  if (*s == '-') s++;
  if (*s == '0') {
    s++;
  } else if (isdigit((unsigned char)*s)) {
    while (isdigit((unsigned char)*s)) s++;
  } else {
    return 0;
  }
  if (*s == '.') {
    s++;
    if (!isdigit((unsigned char)*s)) return 0;
    while (isdigit((unsigned char)*s)) s++;
  }
  if (*s == 'e' || *s == 'E') {
    s++;
    if (*s == '+' || *s == '-') s++;
    if (!isdigit((unsigned char)*s)) return 0;
    while (isdigit((unsigned char)*s)) s++;
  }
  if (!isfinite(strtod(j->s, NULL))) return 0;  // beyond a double (1e400): what reads it back gets infinity
  j->s = s;
  return 1;
}

static int json_container(Json* j, char open, char close, int object) {
  if (*j->s != open || ++j->depth > 200) return 0;
  j->s++;
  json_space(j);
  if (*j->s == close) {
    j->s++;
    j->depth--;
    return 1;
  }
  for (;;) {
    json_space(j);
    if (object) {
      if (!json_string(j)) return 0;
      json_space(j);
      if (*j->s++ != ':') return 0;
    }
    if (!json_value(j)) return 0;
    json_space(j);
    if (*j->s == ',') {
      j->s++;
      continue;
    }
    if (*j->s++ != close) return 0;
    j->depth--;
    return 1;
  }
}

static int json_value(Json* j) {
  json_space(j);
  switch (*j->s) {
    case '{': return json_container(j, '{', '}', 1);
    case '[': return json_container(j, '[', ']', 0);
    case '"': return json_string(j);
    case 't': return !strncmp(j->s, "true", 4) ? (j->s += 4, 1) : 0;
    case 'f': return !strncmp(j->s, "false", 5) ? (j->s += 5, 1) : 0;
    case 'n': return !strncmp(j->s, "null", 4) ? (j->s += 4, 1) : 0;
    default: return json_number(j);
  }
}

int mjfx_json_object(const char* text) {
  Json j = {text, 0};
  json_space(&j);
  if (*j.s != '{' || !json_value(&j)) return 0;
  json_space(&j);
  return *j.s == 0;
}
