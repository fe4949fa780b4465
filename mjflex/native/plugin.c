// The engine plugin mjflex.flexure (capability mjPLUGIN_PASSIVE): one instance per element.
//
// init parses and validates the instance's configuration (config.c) and measures the rest
// offset at qpos0 (instances.c); a bad value is mju_warning + return -1, which MuJoCo turns into a
// compile error naming the element. compute adds the element's generalized forces to qfrc_passive.
// Nothing is global but the plugin's registration and the registry below.
//
// The first instance of the plugin in a model (the leader) does the per-step work of all: the
// last instance's init gathers every instance's element into one contiguous table (what the
// mjcb_passive dispatcher evaluates for text records: the same loop), and the other instances'
// compute returns at once. MuJoCo's own loops over plugin instances still cost a few hundred
// instructions per instance and step.
//
// Ownership: the registry of per-mjData states. MuJoCo gives a plugin one word per instance and
// data, d->plugin_data[i], and that word cannot be trusted (tests/test_native_lifecycle.py):
// * MjData.__setstate__ (pickle, multiprocessing, Dask) makes a data with mj_makeData and then
//   overwrites plugin_data with the pickled words: the source data's pointers (alive and in use by
//   it, or freed) or another process's;
// * mujoco.rollout steps a data with any model of equal nv, state and control sizes: the model may
//   have more plugin instances than the data has plugin_data words;
// * mj_copyData into a data laid out for another model leaves the source's words in the slots past
//   the destination's own; MuJoCo's reset passes d->plugin_data[i] for every instance of the model.
// So the plugin keeps its own record of what it made. All of a data's mjflex state is one State
// (its element table, divergence watch, visualization scratch), and a process-wide registry, a
// hash table under one mutex, maps the data's address to it; the State also records the data's
// buffer address when it was made (the generation: a data freed without MuJoCo calling destroy and
// another allocated at the same address is not taken for it). The registry also holds every live
// State's own address, so that a word read from plugin_data is used only when it is a live State
// and the call is for that State's data (the reset callback gets nothing else: it compares the
// plugin_state address, which only that data has). The plugin never dereferences, frees or writes
// through a word it reads from plugin_data, never indexes plugin_data past d->nplugin, and writes
// d->plugin_data[i] (the State, for MuJoCo's reset) only where d->plugin[i] is its own slot.
//
// A data stepped with another model object than its own (Batch.set_models, rollout with a model
// list, an edited copy) reads that model's elements again, into its own State; when they cannot be
// read (sites that no longer meet) it warns once, gives NaN forces with that model, and keeps its
// table for its own model. A data that has no mjflex instance of its own (made from a model without
// elements) cannot hold a State (MuJoCo would never destroy it): its elements are read at every
// evaluation (slow; a warning says so once per process).
//
// Divergence (see elements.h, mjfx_watch_*): the State owns the data's watch. The leader's compute
// first looks at MuJoCo's bad-state counters; its advance, which MuJoCo calls at the end of every
// step, looks again, so that a step MuJoCo judged bad is reported from within that step.
//
// Visualization: the leader's visualize (called by mjv_updateScene) draws every element as a copy
// of its site a's shape coloured by its bending strain, where the site's group is shown.
// Sleeping: the last instance's init warns when sleeping is enabled and an element joins a tree
// that may sleep (MuJoCo ignores forces on sleeping trees; the plugin cannot change the model).

#include <math.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <mujoco/mjplugin.h>
#include <mujoco/mujoco.h>

#include "config.h"
#include "elements.h"
#include "instances.h"
#include "states.h"

// The plugin's registered slot (-1 until registration; compute never runs before it; instances.c is told).
static int g_slot = -1;

// What identifies the model a table was read from. Beyond the model's address and its configuration
// strings' address (another model object: read again), the sizes the table's indices depend on, so
// that no index can leave the arrays of the model it is used with.
typedef struct ModelKey_ {
  const mjModel* m;
  const char* attr;
  uint64_t signature;
  mjtSize nq, nv, nbody, nsite, nplugin, npluginattr;
} ModelKey;

typedef struct State_ {
  const mjData* data;    // the data it belongs to
  const void* buffer;    // data->buffer when it was made (the generation)
  uintptr_t state_base;  // data->plugin_state, as last seen (the reset callback's check)
  int last;              // during init: the model's last instance of the plugin
  int nparts, counted;   // during init: instances read so far; elements counted in g_live
  Part* parts;
  Table* table;          // from the last instance's init on
  ModelKey key;          // the model the table was read from
  ModelKey refused;      // the last model whose elements could not be read (NaN forces with it)
  mjfxWatch* watch;      // tallies by element of the table
  double* twists;        // 6 per element of the table, for visualize (allocated on first use)
  unsigned char* model;  // the snapshot of the model the table was read from (states.h: in-place edits)
  int checked;           // the snapshot was compared in this step, at d->time `at` (advance and reset clear it)
  double at;
  int settled;           // its configuration text was compared in this run (reset clears it)
  int edited;            // a read after an in-place edit was said (once per data)
} State;

// the model's first (leader) and last instance of the plugin, -1 if none
static int first_of(const mjModel* m) {
  for (int i = 0; i < m->nplugin; i++) {
    if (m->plugin[i] == g_slot) return i;
  }
  return -1;
}

static int last_of(const mjModel* m) {
  for (int i = (int)m->nplugin - 1; i >= 0; i--) {
    if (m->plugin[i] == g_slot) return i;
  }
  return -1;
}

static int count_of(const mjModel* m) {
  int n = 0;
  for (int i = 0; i < m->nplugin; i++) n += m->plugin[i] == g_slot;
  return n;
}

// whether d has an instance of the plugin in its own arrays (then MuJoCo calls destroy for d)
static int data_has_instance(const mjData* d) {
  for (int i = 0; i < d->nplugin; i++) {
    if (d->plugin[i] == g_slot) return 1;
  }
  return 0;
}

static ModelKey key_of(const mjModel* m) {
  ModelKey k = {m, m->plugin_attr, m->signature, m->nq, m->nv, m->nbody, m->nsite, m->nplugin, m->npluginattr};
  return k;
}

static int key_is(const ModelKey* k, const mjModel* m) {
  return k->m == m && k->attr == m->plugin_attr && k->signature == m->signature && k->nq == m->nq &&
         k->nv == m->nv && k->nbody == m->nbody && k->nsite == m->nsite && k->nplugin == m->nplugin &&
         k->npluginattr == m->npluginattr;
}

//------------------------------------------------------------------------------ tables and states

// elements alive in the process (a test checks that failed compiles and freed datas leave none behind)
static _Atomic long g_live = 0;

long mjfx_live_instances(void) {
  return atomic_load(&g_live);
}

static void free_parts(State* s) {
  for (int k = 0; k < s->nparts; k++) mjfx_free_part(s->parts + k);
  free(s->parts);
  s->parts = NULL;
  s->nparts = 0;
}

// free a state that is not (or no longer) in the registry
static void free_state(void* p) {
  State* s = (State*)p;
  if (!s) return;
  atomic_fetch_sub(&g_live, s->counted);
  free_parts(s);
  mjfx_free_table(s->table);
  free(s->watch);
  free(s->twists);
  free(s->model);
  free(s);
}

// the state's watch for n elements: kept when it has n tallies (a run goes on), else a fresh one
static int size_watch(State* s, int n) {
  if (s->watch && s->watch->n == n) return 0;
  mjfxWatch* w = malloc(mjfx_watch_size(n));
  if (!w) return -1;
  free(s->watch);
  s->watch = w;
  w->exact = 1;
  mjfx_watch_clear(w, n);
  return 0;
}

// install table t (read from m) in s, replacing its table; -1: out of memory (t freed)
static int install_table(State* s, const mjModel* m, Table* t) {
  unsigned char* snapshot = malloc(mjfx_snapshot_size(m) + 1);
  if (!snapshot || size_watch(s, t->n)) {
    free(snapshot);
    mjfx_free_table(t);
    return -1;
  }
  mjfx_snapshot_take(m, snapshot);
  free(s->model);
  s->model = snapshot;
  s->checked = s->settled = 0;  // compared at the first evaluation (an edit may come before the first step)
  atomic_fetch_add(&g_live, t->n - (s->table ? s->table->n : 0));
  s->counted += t->n - (s->table ? s->table->n : 0);
  mjfx_free_table(s->table);
  free(s->twists);
  s->twists = NULL;
  s->table = t;
  s->key = key_of(m);
  memset(&s->refused, 0, sizeof(ModelKey));
  return 0;
}

// the state of d in the registry, made if d has none (NULL: out of memory)
static State* state_new(const mjData* d) {
  State* s = calloc(1, sizeof(State));
  if (!s) return NULL;
  s->data = d, s->buffer = d->buffer, s->state_base = (uintptr_t)d->plugin_state;
  if (mjfx_states_add(d, d->buffer, s, free_state)) {
    free(s);
    return NULL;
  }
  return s;
}

// Write the state into d's own words of the plugin (where d->plugin[i] is its slot; 0 for none).
static void own_words(mjData* d, const State* s) {
  for (int i = 0; i < d->nplugin; i++) {
    if (d->plugin[i] == g_slot) d->plugin_data[i] = (uintptr_t)s;
  }
}

//------------------------------------------------------------------------------ callbacks

// A failed init: report, and drop d's state (MuJoCo calls no destroy for the failed instance; MuJoCo 4.0.0
// destroys the instances it had initialized, the 3.x source frees the mjData without destroying them: either
// way nothing leaks and nothing is freed twice, as the registry, not plugin_data, holds what was made).
static int init_fail(mjData* d, const char* msg) {
  mju_warning("%s", msg);
  mjfx_states_remove(d);
  for (int i = 0; i < d->nplugin; i++) {
    if (d->plugin[i] == g_slot) d->plugin_data[i] = 0;
  }
  return -1;
}

// The last instance's init: the parts become the table.
static int init_table(const mjModel* m, State* s) {
  int* instance = malloc(sizeof(int) * (s->nparts ? s->nparts : 1));
  Table* t = NULL;
  if (instance) {
    for (int i = 0, k = 0; i < m->nplugin; i++) {
      if (m->plugin[i] == g_slot && k < s->nparts) instance[k++] = i;
    }
    t = mjfx_gather(s->parts, instance, s->nparts, 0);
  }
  free(instance);
  atomic_fetch_sub(&g_live, s->nparts);
  s->counted -= s->nparts;
  free_parts(s);
  if (!t || install_table(s, m, t)) return -1;
  mjfx_warn_sleepy(m, s->table);
  return 0;
}

static int flexure_init(const mjModel* m, mjData* d, int instance) {
  char err[1000];
  if (instance >= d->nplugin) return init_fail(d, "mjflex: internal error: an instance past the data's own");
  State* s = NULL;
  if (instance == first_of(m)) {  // the leader: a fresh state for d (one left by a data that lived here goes)
    mjfx_states_remove(d);
    s = state_new(d);
    if (s) {
      s->last = last_of(m);
      s->parts = calloc(count_of(m), sizeof(Part));
    }
    if (!s || !s->parts) return init_fail(d, "mjflex: out of memory");
  } else {
    s = (State*)mjfx_states_find(d, d->buffer);
    if (!s || !s->parts) return init_fail(d, "mjflex: internal error: an instance initialized before the first");
  }
  double* saved = mjfx_measure_begin(m, d);
  if (!saved) return init_fail(d, "mjflex: out of memory");
  int failed = mjfx_read_part(m, d, instance, s->parts + s->nparts, 0, err, sizeof(err));
  mjfx_measure_end(m, d, saved, 0);  // a fresh data: MuJoCo resets it next
  if (failed) return init_fail(d, err);
  s->nparts++, s->counted++;
  atomic_fetch_add(&g_live, 1);
  if (instance == s->last && init_table(m, s)) return init_fail(d, "mjflex: out of memory");
  own_words(d, s);
  return 0;
}

static void flexure_destroy(mjData* d, int instance) {
  mjfx_states_remove(d);  // whatever d->plugin_data holds: only the registry says what is d's
  if (instance >= 0 && instance < d->nplugin) d->plugin_data[instance] = 0;
}

// Elements of a data without a state of its own (see the top): read, evaluated and freed at every call;
// said once per process (and once more if they cannot be read: NaN forces then).
static _Atomic int g_warned_stateless = 0, g_warned_unread = 0;

static Table* stateless_table(const mjModel* m, mjData* d) {
  char err[1000];
  if (!atomic_exchange(&g_warned_stateless, 1)) {
    mju_warning("mjflex: a data made from a model without mjflex.flexure instances is stepped with model '%.100s', "
                "which has them: its elements are read again at every step (slow). Make the data from the model "
                "you step it with (mujoco.MjData(model)); this is said once per process",
                m->names[0] ? m->names : "unnamed");
  }
  Table* t = mjfx_read_model(m, d, g_slot, err, sizeof(err));
  if (!t && !atomic_exchange(&g_warned_unread, 1)) {
    mju_warning("%s. mjflex: so the elements of model '%.100s' cannot be read for a data made from another model: "
                "its forces are NaN", err, m->names[0] ? m->names : "unnamed");
  }
  return t;
}

// The state of d holding model m's elements, reading them when d's table is another model's, or m's
// before an in-place edit (where `check`: compared at a step's first evaluation, or at one again at the
// time of the last comparison, as repeated mj_forward calls; the configuration text where a run starts). NULL, with a warning once per model,
// when they cannot be read (or d cannot hold a state: *temp gets a table to free).
static State* state_for(const mjModel* m, mjData* d, Table** temp, int check) {
  char err[1000];
  *temp = NULL;
  State* s = (State*)mjfx_states_find(d, d->buffer);
  if (!s && !data_has_instance(d)) {
    *temp = stateless_table(m, d);
    return NULL;
  }
  if (!s && !(s = state_new(d))) return NULL;
  s->state_base = (uintptr_t)d->plugin_state;
  int edited = 0;
  if (s->table && key_is(&s->key, m)) {
    if (check && (!s->checked || d->time == s->at)) {  // a step's first evaluation, or one again at its time
      edited = !mjfx_snapshot_same(m, s->model, !s->settled);
      s->checked = s->settled = 1, s->at = d->time;
    }
    if (!edited) {
      int i = s->table->n ? s->table->instance[0] : -1;  // the model's leader: d's own word, if d has it
      if (i >= 0 && i < d->nplugin && d->plugin[i] == g_slot && d->plugin_data[i] != (uintptr_t)s) own_words(d, s);
      return s;
    }
    memset(&s->key, 0, sizeof(ModelKey));  // read m again below; if that fails, m is refused (NaN forces)
  }
  if (key_is(&s->refused, m)) return NULL;
  Table* t = mjfx_read_model(m, d, g_slot, err, sizeof(err));
  if (t && !install_table(s, m, t)) {
    own_words(d, s);
    if (edited && !s->edited) {
      s->edited = 1;
      mju_warning("mjflex: model '%.100s' was edited in place after this data was made (a field its elements are "
                  "read from: a site's or body's pose, qpos0, a joint, a mass, the configuration): its elements were "
                  "read again from the model as it is now, rest poses at its qpos0, as a new MjData would. Edit the "
                  "spec and compile it, or make a new MjData, after such an edit; this is said once per data",
                  m->names[0] ? m->names : "unnamed");
    }
    return s;
  }
  s->refused = key_of(m);
  if (edited) {
    mju_warning("%s. mjflex: so the elements of model '%.100s', edited in place after this data was made, cannot be "
                "read again: its forces are NaN with this data. Undo the edit, or edit the spec and compile it",
                t ? "mjflex: out of memory" : err, m->names[0] ? m->names : "unnamed");
    return NULL;
  }
  mju_warning("%s. mjflex: so the elements of model '%.100s', with which a data made from another model is stepped, "
              "cannot be read: its forces are NaN with that model (the data's own model still works). Make the data "
              "from the model you step it with (mujoco.MjData(model))",
              t ? "mjflex: out of memory" : err, m->names[0] ? m->names : "unnamed");
  return NULL;
}

// whether `instance` is the model's first instance of the plugin (the one that does the work)
static int is_leader(const mjModel* m, int instance) {
  if (instance > 0 && m->plugin[instance - 1] == g_slot) return 0;  // most models: at once
  return first_of(m) == instance;
}

static void report(const mjModel* m, const Table* t, const mjfxVerdict* v) {
  if (v->element >= 0 && v->element < t->n) mjfx_report(m, v, mjfx_instance_name(m, t->instance[v->element]));
}

static void nan_forces(const mjModel* m, mjData* d) {
  for (int i = 0; i < m->nv; i++) d->qfrc_passive[i] = NAN;  // so that MuJoCo's checks see it too
}

static void flexure_compute(const mjModel* m, mjData* d, int instance, int capability_bit) {
  if (!is_leader(m, instance)) return;
  Table* temp;
  State* s = state_for(m, d, &temp, 1);
  if (!s) {
    if (!temp || mjfx_evaluate(m, d, temp->el, temp->n, temp->chain, temp->exps, temp->coefs, MJFX_APPLY,
                               d->qfrc_passive, NULL, NULL, NULL) >= 0) {
      nan_forces(m, d);  // no force is silently lost
    }
    mjfx_free_table(temp);
    return;
  }
  Table* t = s->table;
  mjfxVerdict v;
  mjfx_watch_judge(s->watch, m, d, 1, &v);
  report(m, t, &v);
  mjfxScan scan;
  int bad = mjfx_evaluate(m, d, t->el, t->n, t->chain, t->exps, t->coefs, MJFX_APPLY, d->qfrc_passive, NULL, NULL,
                          &scan);
  if (bad >= 0) nan_forces(m, d);
  mjfx_watch_record(s->watch, m, d, &scan, 1, &v);
  report(m, t, &v);
}

static void flexure_advance(const mjModel* m, mjData* d, int instance) {
  if (!is_leader(m, instance)) return;
  Table* temp;
  State* s = state_for(m, d, &temp, 0);
  mjfx_free_table(temp);
  if (!s) return;
  s->checked = 0;  // the next step's first evaluation compares the model with its snapshot
  mjfxVerdict v;
  mjfx_watch_judge(s->watch, m, d, 1, &v);
  mjfx_watch_step_end(s->watch, d);
  report(m, s->table, &v);
}

// the copy continues the run: the source's tallies, where both datas hold states of the same size
static void flexure_copy(mjData* dest, const mjModel* m, const mjData* src, int instance) {
  if (!is_leader(m, instance)) return;
  State* to = (State*)mjfx_states_find(dest, dest->buffer);
  const State* from = (const State*)mjfx_states_find(src, src->buffer);
  if (to && from && to->watch && from->watch && to->watch->n == from->watch->n) {
    memcpy(to->watch, from->watch, mjfx_watch_size(from->watch->n));
  }
  own_words(dest, to);  // not the source's words, which mj_copyData leaves past dest's own
}

// A reset: MuJoCo passes d->plugin_data[instance] and d's plugin_state, not d: the word counts only if
// it is a live state whose data has that plugin_state (see the top).
static void flexure_reset(const mjModel* m, mjtNum* plugin_state, void* plugin_data, int instance) {
  uintptr_t base = (uintptr_t)plugin_state - (uintptr_t)(sizeof(mjtNum) * (size_t)m->plugin_stateadr[instance]);
  State* s = (State*)mjfx_states_lock_live((uintptr_t)plugin_data);
  if (s && s->state_base == base && s->watch) s->watch->reset = 1;  // a new run, unless MuJoCo counts a bad state
  if (s && s->state_base == base) s->checked = s->settled = 0;        // and the model is compared at its start
  mjfx_states_unlock();
}

static int flexure_nstate(const mjModel* m, int instance) {
  return 0;
}

// The strain colour of mjflex.app.render.strain_colors: green (0) through yellow (half) to red (full scale).
static void strain_color(double x, float rgba[4]) {
  x = x > 0 ? (x < 1 ? x : 1) : 0;  // NaN: green
  double r = 2 * x, g = 2 * (1 - x);
  rgba[0] = (float)(r < 1 ? r : 1);
  rgba[1] = (float)(0.85 * (g < 1 ? g : 1));
  rgba[2] = 0.1f;
  rgba[3] = 1.0f;
}

// Draw every element (leader only) as its site a's shape, 10 % larger so that it covers the site, at the
// site's pose, coloured by |rotation about z| x strain_per_radian over the full scale strain_scale (the rotation
// itself without strain_per_radian; both display attributes, read from the configuration here); where site a's
// group is shown, while the scene has room.
static void flexure_visualize(const mjModel* m, mjData* d, const mjvOption* opt, mjvScene* scn, int instance) {
  if (!is_leader(m, instance)) return;
  Table* temp;
  State* s = state_for(m, d, &temp, 0);
  mjfx_free_table(temp);
  if (!s || !s->table->n) return;
  Table* t = s->table;
  if (!s->twists && !(s->twists = malloc(sizeof(double) * 6 * t->n))) return;
  mjfxScan scan;
  mjfx_evaluate(m, d, t->el, t->n, t->chain, t->exps, t->coefs, MJFX_COORDS, NULL, s->twists, NULL, &scan);
  for (int k = 0; k < t->n && scn->ngeom < scn->maxgeom; k++) {
    int site = t->el[k].site_a;
    int group = m->site_group[site];
    if (!opt->sitegroup[group < 0 ? 0 : (group >= mjNGROUP ? mjNGROUP - 1 : group)]) continue;
    double per_radian = mjfx_config_number(m, t->instance[k], MJFX_A_STRAIN, 0);
    double scale = mjfx_config_number(m, t->instance[k], MJFX_A_STRAIN_SCALE, 0);
    double bending = fabs(s->twists[6 * k + 2]);
    double value = per_radian > 0 ? bending * per_radian : bending;
    double full = scale > 0 ? scale : (per_radian > 0 ? MJFX_DEFAULT_STRAIN_SCALE : MJFX_DEFAULT_ROTATION_SCALE);
    float rgba[4];
    strain_color(value / full, rgba);
    mjtNum size[3];
    for (int i = 0; i < 3; i++) size[i] = 1.1 * m->site_size[3 * site + i];
    mjvGeom* g = scn->geoms + scn->ngeom;
    memset(g, 0, sizeof(mjvGeom));
    mjv_initGeom(g, m->site_type[site], size, d->site_xpos + 3 * site, d->site_xmat + 9 * site, rgba);
    g->objtype = mjOBJ_PLUGIN;
    g->objid = t->instance[k];
    g->category = mjCAT_DECOR;
    g->segid = scn->ngeom;
    if (opt->label == mjLABEL_SITE) snprintf(g->label, sizeof(g->label), "%s", mjfx_instance_name(m, t->instance[k]));
    scn->ngeom++;
  }
}

//------------------------------------------------------------------------------ for Python (ctypes)

// The divergence watch of d (tallies indexed by the model's instances of the plugin, in order), or NULL.
const mjfxWatch* mjfx_plugin_watch(const mjModel* m, const mjData* d) {
  const State* s = (const State*)mjfx_states_find(d, d->buffer);
  return s && s->table && s->watch && s->table->n == count_of(m) ? s->watch : NULL;
}

//------------------------------------------------------------------------------ registration

// The MuJoCo version whose headers this was compiled against (a test builds a copy that claims another).
#ifndef MJFX_HEADER_VERSION
#define MJFX_HEADER_VERSION mjVERSION_HEADER
#endif

// 0 until registration ran: 1 registered, -1 refused (header and library versions differ), -2 not
// registered because another copy of the library (loaded from another path) registered the plugin first
static int g_status = 0;

int mjfx_status(void) {
  return g_status;
}

int mjfx_header_version(void) {
  return MJFX_HEADER_VERSION;
}

mjPLUGIN_LIB_INIT(mjflex_flexure) {
  if (mj_version() != MJFX_HEADER_VERSION) {
    mju_warning(
        "mjflex: this build of the mjflex.flexure plugin was compiled against the headers of MuJoCo %d but is loaded "
        "by MuJoCo %d (mjModel and mjData change between releases); it is not registered. Rebuild it against the "
        "installed mujoco: pip install --force-reinstall --no-deps --no-build-isolation <mjflex source>",
        MJFX_HEADER_VERSION, mj_version());
    g_status = -1;
    return;
  }
  int slot = -1;
  const mjpPlugin* other = mjp_getPlugin(MJFX_PLUGIN_NAME, &slot);
  if (other && other->init != flexure_init) {
    // Registering a different plugin under the same name is a MuJoCo error, which ends a program without
    // an error handler (a ctypes.CDLL of a copy of this file): the first copy stays the plugin.
    g_status = -2;
    return;
  }
  static const char* attributes[MJFX_NATTRIBUTE];  // the table's keys (MuJoCo keeps the pointer)
  for (int i = 0; i < MJFX_NATTRIBUTE; i++) attributes[i] = MJFX_SCHEMA[i].key;
  mjpPlugin plugin;
  mjp_defaultPlugin(&plugin);
  plugin.name = MJFX_PLUGIN_NAME;
  plugin.capabilityflags |= mjPLUGIN_PASSIVE;
  plugin.nattribute = MJFX_NATTRIBUTE;
  plugin.attributes = attributes;
  plugin.nstate = flexure_nstate;
  plugin.init = flexure_init;
  plugin.destroy = flexure_destroy;
  plugin.copy = flexure_copy;
  plugin.reset = flexure_reset;
  plugin.compute = flexure_compute;
  plugin.advance = flexure_advance;
  plugin.visualize = flexure_visualize;
  g_slot = mjp_registerPlugin(&plugin);
  mjfx_set_plugin_slot(g_slot);
  g_status = 1;
}
