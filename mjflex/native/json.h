// Whether a text is one complete JSON object (RFC 8259; no NaN or Infinity, and every number a finite double, so
// that what reads it back gets the numbers it holds): an element's source.

#ifndef MJFLEX_NATIVE_JSON_H_
#define MJFLEX_NATIVE_JSON_H_

// 1 when text is one JSON object (white space around it allowed), else 0.
int mjfx_json_object(const char* text);

#endif  // MJFLEX_NATIVE_JSON_H_
