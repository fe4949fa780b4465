// Reading elements from a model, both forms (plugin.c's instances, and the text records mjflex's Python
// layer gives as configuration strings): each element's configuration parsed and checked (config.c), its
// sites found (also under MjSpec.attach's prefixes), its rest offset measured at the reference
// configuration, its dof chains; and the gathered table of a model's elements that the per-step loop
// evaluates. The element set-up exists here only. Nothing here keeps state between calls.

#ifndef MJFLEX_NATIVE_INSTANCES_H_
#define MJFLEX_NATIVE_INSTANCES_H_

#include <mujoco/mujoco.h>

#include "elements.h"
#include "schema.h"

// One instance's element as its init reads it (own dof chain and terms, indices from 0), and the values of its
// configuration when they are kept (for Python).
typedef struct Part_ {
  mjfxElement el;
  int *chain, *exps;
  double* coefs;
  int nchain, nterms;
  mjfxValues values;
} Part;

// All elements of a model, gathered.
typedef struct Table_ {
  int n, nchain, nterms;
  mjfxElement* el;
  int* chain;
  int* exps;
  double* coefs;
  int* instance;        // plugin instance of each element (-1: a text record)
  mjfxValues* values;   // each element's configuration values (mjfx_read_table), else NULL
} Table;

// the name of plugin instance `instance` (its element's name)
const char* mjfx_instance_name(const mjModel* m, int instance);

void mjfx_free_part(Part* p);
void mjfx_free_table(Table* t);

// Gather parts (in instance order; instance[k] is part k's plugin instance) into one table, the chain and
// term ranges shifted into the concatenated arrays; the parts' values move into it (with `values`). NULL: out of
// memory.
Table* mjfx_gather(Part* parts, const int* instance, int n, int values);

// The reference configuration in d's kinematics, for reading elements: qpos0 and the mocap bodies at their
// model poses (what mj_resetData sets). The caller's qpos and mocap poses are saved in what it returns (NULL:
// out of memory) and put back by mjfx_measure_end, with `kinematics`, d's kinematics too (bit for bit).
double* mjfx_measure_begin(const mjModel* m, mjData* d);
void mjfx_measure_end(const mjModel* m, mjData* d, double* saved, int kinematics);

// The coincidence tolerance [m] of sites sa and sb: MJFX_COINCIDENCE_RTOL times their length scale.
double mjfx_coincidence_tolerance(const mjModel* m, int sa, int sb);

// Whether two rest offsets of one element (a, b: its rows in two tables of m's elements) coincide within
// the element's tolerances; gap: their distance [m] and angle [rad].
int mjfx_offsets_coincide(const mjModel* m, const mjfxElement* a, const mjfxElement* b, double gap[2]);

// Read element `name`, written in `form` (MJFX_FORM_*), from its configuration strings values[MJFX_NATTRIBUTE]
// into p, d holding the kinematics of the reference configuration (mjfx_measure_begin): parsed and checked
// (config.c), its sites found and on two bodies, its rest offset measured and checked (the sites coincide,
// the frame site too), its derived fields, inverse inertias and dof chains. The one reader of both forms:
// every check has one message, in the words of the form. The values read are kept in p->values with `keep`.
// 0, or -1 with the message in err (p holds nothing).
int mjfx_read_element(const mjModel* m, const mjData* d, const char* name, int form, const char* const* values,
                      Part* p, int keep, char* err, int errsz);

// Read instance `instance` of m into p (mjfx_read_element with its <config> strings).
int mjfx_read_part(const mjModel* m, const mjData* d, int instance, Part* p, int keep, char* err, int errsz);

// Every instance of the plugin at `slot` in m, read on d (d's kinematics are put back bit for bit): the
// table, or NULL with a message in err.
Table* mjfx_read_model(const mjModel* m, mjData* d, int slot, char* err, int errsz);

// For Python (mjflex.runtime.tables): nrec text records (names[k] and their configuration strings values[k *
// MJFX_NATTRIBUTE ...]) and then every instance of the plugin, read on d as mjfx_read_model does, each element's
// values kept. The table (free it with mjfx_free_table), or NULL with the message in err.
Table* mjfx_read_table(const mjModel* m, mjData* d, int nrec, const char* const* names, const char* const* values,
                       char* err, int errsz);

// The plugin's registered slot (-1 before registration): plugin.c sets it when it registers the plugin.
int mjfx_plugin_slot(void);
void mjfx_set_plugin_slot(int slot);

// With sleeping enabled, warn about an element that joins a tree which may sleep (see instances.c).
void mjfx_warn_sleepy(const mjModel* m, const Table* t);

#endif  // MJFLEX_NATIVE_INSTANCES_H_
