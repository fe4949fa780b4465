// The engine plugin mjflex.flexure (capability mjPLUGIN_PASSIVE): one instance per element.
//
// init parses and validates the instance's configuration (config.c) and measures the rest
// offset at qpos0; a bad value is mju_warning + return -1, which MuJoCo turns into a compile
// error naming the element. compute adds the element's generalized forces to qfrc_passive.
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
#include "states.h"

// The plugin's registered slot (-1 until registration; compute never runs before it).
static int g_slot = -1;

// One instance's element as its init reads it (own dof chain and terms, indices from 0).
typedef struct Part_ {
  mjfxElement el;
  int *chain, *exps;
  double* coefs;
  int nchain, nterms;
  double strain[2];  // strain_per_radian, strain_scale (0: not given)
} Part;

// All elements of a model, gathered.
typedef struct Table_ {
  int n;
  mjfxElement* el;
  int* chain;
  int* exps;
  double* coefs;
  int* instance;   // plugin instance of each element
  double* strain;  // 2 per element: strain_per_radian, strain_scale
} Table;

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
} State;

static const char* instance_name(const mjModel* m, int instance) {
  return m->names + m->name_pluginadr[instance];
}

static int is_ours(const mjModel* m, int i) {
  return i >= 0 && i < m->nplugin && m->plugin[i] == g_slot;
}

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

static void free_part(Part* p) {
  free(p->chain);
  free(p->exps);
  free(p->coefs);
  memset(p, 0, sizeof(Part));
}

static void free_table(Table* t) {
  if (!t) return;
  free(t->el);
  free(t->chain);
  free(t->exps);
  free(t->coefs);
  free(t->instance);
  free(t->strain);
  free(t);
}

static void free_parts(State* s) {
  for (int k = 0; k < s->nparts; k++) free_part(s->parts + k);
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
  free_table(s->table);
  free(s->watch);
  free(s->twists);
  free(s);
}

// Gather parts (in instance order) into one table, the chain and term ranges shifted into the
// concatenated arrays. NULL: out of memory.
static Table* gather(const Part* parts, const int* instance, int n) {
  Table* t = calloc(1, sizeof(Table));
  if (!t) return NULL;
  int nchain = 0, nterms = 0;
  for (int k = 0; k < n; k++) nchain += parts[k].nchain, nterms += parts[k].nterms;
  t->el = malloc(sizeof(mjfxElement) * (n ? n : 1));
  t->instance = malloc(sizeof(int) * (n ? n : 1));
  t->strain = malloc(sizeof(double) * 2 * (n ? n : 1));
  t->chain = malloc(sizeof(int) * (nchain ? nchain : 1));
  t->exps = calloc((size_t)(nterms ? nterms : 1) * MJFX_TERM_COLUMNS, sizeof(int));
  t->coefs = calloc(nterms ? nterms : 1, sizeof(double));
  if (!t->el || !t->instance || !t->strain || !t->chain || !t->exps || !t->coefs) {
    free_table(t);
    return NULL;
  }
  int c = 0, r = 0;
  for (int k = 0; k < n; k++) {
    const Part* p = parts + k;
    mjfxElement* e = t->el + k;
    *e = p->el;
    e->chain_a0 += c, e->chain_a1 += c, e->chain_b0 += c, e->chain_b1 += c;
    e->terms_lo += r, e->terms_hi += r;
    if (p->nchain) memcpy(t->chain + c, p->chain, sizeof(int) * p->nchain);
    if (p->nterms) {
      memcpy(t->exps + MJFX_TERM_COLUMNS * r, p->exps, sizeof(int) * MJFX_TERM_COLUMNS * p->nterms);
      memcpy(t->coefs + r, p->coefs, sizeof(double) * p->nterms);
    }
    t->instance[k] = instance[k];
    t->strain[2 * k] = p->strain[0], t->strain[2 * k + 1] = p->strain[1];
    c += p->nchain, r += p->nterms;
  }
  t->n = n;
  return t;
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
  if (size_watch(s, t->n)) {
    free_table(t);
    return -1;
  }
  atomic_fetch_add(&g_live, t->n - (s->table ? s->table->n : 0));
  s->counted += t->n - (s->table ? s->table->n : 0);
  free_table(s->table);
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

//------------------------------------------------------------------------------ reading an element

// the text record of the same element, if the model has one (a model must hold each element once)
static const char* record_of(const mjModel* m, const char* name) {
  static const char prefix[] = "mjflex:";
  for (int t = 0; t < m->ntext; t++) {
    const char* tname = m->names + m->name_textadr[t];
    const char* at = strstr(tname, prefix);
    if (!at) continue;
    size_t head = (size_t)(at - tname), len = strlen(name);
    if (strlen(tname) == len + sizeof(prefix) - 1 && !strncmp(tname, name, head) &&
        !strcmp(at + sizeof(prefix) - 1, name + head)) {
      return tname;
    }
  }
  return NULL;
}

// Id of the site a configuration names: `value` itself or, in a model composed with MjSpec.attach
// (which prefixes and suffixes every name but leaves configuration strings as written), P + value + S
// where the instance's name is P + E + S (mjflex.mj.schema.attached_name, the same rule). -1: none.
static int config_site(const mjModel* m, const char* instance_name, const char* value) {
  int id = mj_name2id(m, mjOBJ_SITE, value);
  if (id >= 0 || !value[0]) return id;
  size_t nlen = strlen(instance_name), vlen = strlen(value);
  for (int i = 0; i < m->nsite; i++) {
    const char* s = m->names + m->name_siteadr[i];
    size_t slen = strlen(s);
    for (const char* at = strstr(s, value); at; at = strstr(at + 1, value)) {
      size_t pre = (size_t)(at - s), suf = slen - pre - vlen;
      if (pre + suf < nlen && !strncmp(instance_name, s, pre) && !strcmp(instance_name + nlen - suf, at + vlen)) {
        return i;
      }
    }
  }
  return -1;
}

// Whether a distance and an angle are within the coincidence tolerances; NaN is not (a NaN or
// infinite position or orientation in the model would otherwise pass: NaN > tol is false).
static int coincide(double dist, double angle, double tol) {
  return dist <= tol && angle <= MJFX_COINCIDENCE_ANGLE;
}

static const char NONFINITE[] =
    "Their pose at qpos0 is not finite: a position, orientation or joint reference (qpos0) that places them "
    "is NaN or infinite; give finite numbers";

// The optional frame site (attribute "site", written by add_flexure(..., site=...)): it must exist and
// coincide with frame a at qpos0 (d holds the kinematics at qpos0). Returns 0 or -1 with a message.
static int check_frame_site(const mjModel* m, const mjData* d, const char* name, const char* value, int site_a,
                            double tol, char* err, int errsz) {
  if (!value[0]) return 0;
  int id = config_site(m, name, value);
  if (id < 0) {
    snprintf(err, errsz,
             "mjflex: flexure '%.200s' (plugin instance of %s): its site attribute names the frame site '%.200s', "
             "which the model does not have. Restore the site, or drop the site attribute if site_a and site_b are "
             "right", name, MJFX_PLUGIN_NAME, value);
    return -1;
  }
  double R[9], p[3], dist, angle;
  mjfx_rest_offset(d, id, site_a, R, p, &dist, &angle);
  if (!coincide(dist, angle, tol)) {
    snprintf(err, errsz,
             "mjflex: flexure '%.200s' (plugin instance of %s): its frame is %.3g m and %.3g rad away from the site "
             "'%.200s' its site attribute names (at qpos0). %s", name, MJFX_PLUGIN_NAME, dist, angle, value,
             isfinite(dist) && isfinite(angle)
                 ? "The site was moved without the element: place the element again at the site "
                   "(mjflex.add_flexure(..., site=...) or mjflex.make_compliant), or drop the site attribute"
                 : NONFINITE);
    return -1;
  }
  return 0;
}

// the two sites of an instance (ids into sites[2]); 0 or -1 with a message
static int read_sites(const mjModel* m, const char* name, const char* const* values, int sites[2], char* err,
                      int errsz) {
  for (int k = 0; k < 2; k++) {
    const char* key = k ? "site_b" : "site_a";
    const char* site = values[k];
    if (!site[0]) {
      snprintf(err, errsz,
               "mjflex: flexure '%.200s' (plugin instance of %s): %s is missing. Add <config key=\"%s\" "
               "value=\"SITE\"/> naming the site of the element frame on body %s",
               name, MJFX_PLUGIN_NAME, key, key, k ? "B" : "A");
      return -1;
    }
    sites[k] = config_site(m, name, site);
    if (sites[k] < 0) {
      snprintf(err, errsz,
               "mjflex: flexure '%.200s' (plugin instance of %s): %s '%.200s' is not a site of the model. Add <site "
               "name=\"%.200s\"/> at the element frame (body %s) or fix the name",
               name, MJFX_PLUGIN_NAME, key, site, site, k ? "B" : "A");
      return -1;
    }
  }
  if (m->site_bodyid[sites[0]] == m->site_bodyid[sites[1]]) {
    snprintf(err, errsz,
             "mjflex: flexure '%.200s' (plugin instance of %s): both sites are on body '%.200s'. Put site_a on one "
             "body and site_b on the other (a site of the world body grounds the element)",
             name, MJFX_PLUGIN_NAME, m->names + m->name_bodyadr[m->site_bodyid[sites[0]]]);
    return -1;
  }
  return 0;
}

// The rest offset of the sites (d holds the kinematics of the reference configuration): it must be the
// identity within the coincidence tolerance. 0 or -1 with a message.
static int read_rest_offset(const mjModel* m, const mjData* d, const char* name, const char* const* values,
                            mjfxElement* e, char* err, int errsz) {
  double dist, angle;
  mjfx_rest_offset(d, e->site_a, e->site_b, e->R0, e->p0, &dist, &angle);
  double scale = mjfx_length_scale(m, e->site_a, e->site_b);
  double tol = MJFX_COINCIDENCE_RTOL * (scale > 1e-9 ? scale : 1e-9);
  if (!coincide(dist, angle, tol)) {
    int finite = isfinite(dist) && isfinite(angle) && isfinite(scale);
    snprintf(err, errsz,
             "mjflex: flexure '%.200s' (plugin instance of %s): sites '%.100s' and '%.100s' are %.3g m apart and "
             "%.3g rad apart at qpos0 (tolerance %.3g m: %g times the %.3g m of site and body positions that place "
             "them, which covers their 6-digit rounding in saved files; %g rad). %s",
             name, MJFX_PLUGIN_NAME, values[0], values[1], dist, angle, tol, MJFX_COINCIDENCE_RTOL, scale,
             MJFX_COINCIDENCE_ANGLE,
             finite ? "Both frames must coincide in the reference configuration: place both at the same world pose"
                    : NONFINITE);
    return -1;
  }
  return check_frame_site(m, d, name, values[MJFX_NATTRIBUTE - 1], e->site_a, tol, err, errsz);
}

// Read instance `instance` of m into p, d holding the kinematics of the reference configuration
// (measure_begin). 0, or -1 with a message in err (p holds nothing then).
static int read_part(const mjModel* m, const mjData* d, int instance, Part* p, char* err, int errsz) {
  memset(p, 0, sizeof(Part));
  const char* name = instance_name(m, instance);
  if (!name[0]) {
    snprintf(err, errsz,
             "mjflex: an instance of plugin %s (instance %d) has no name; an element is known by its name: declare it "
             "as <instance name=\"...\"> under <extension><plugin plugin=\"%s\">",
             MJFX_PLUGIN_NAME, instance, MJFX_PLUGIN_NAME);
    return -1;
  }
  const char* values[MJFX_NATTRIBUTE];
  for (int i = 0; i < MJFX_NATTRIBUTE; i++) {
    values[i] = mj_getPluginConfig(m, instance, MJFX_ATTRIBUTES[i]);
    if (!values[i]) values[i] = "";
  }
  mjfxParsed parsed;
  memset(&parsed, 0, sizeof(parsed));
  if (mjfx_parse_config(name, values, &parsed, err, errsz)) return -1;
  p->el = parsed.el;
  p->exps = parsed.exps, p->coefs = parsed.coefs, p->nterms = parsed.nterms;
  p->strain[0] = parsed.strain_per_radian, p->strain[1] = parsed.strain_scale;
  mjfxElement* e = &p->el;
  const char* record = record_of(m, name);
  int sites[2];
  if (record) {
    snprintf(err, errsz,
             "mjflex: flexure '%.200s' is both a plugin instance and the text record '%.200s': its forces would be "
             "added twice. Keep one of them (python -m mjflex convert writes either form)",
             name, record);
  } else if (!read_sites(m, name, values, sites, err, errsz)) {
    e->site_a = sites[0], e->site_b = sites[1];
    e->body_a = m->site_bodyid[sites[0]], e->body_b = m->site_bodyid[sites[1]];
    if (!read_rest_offset(m, d, name, values, e, err, errsz)) {
      mjfx_element_prepare(m, e);
      mjfx_inverse_inertia(m, e->body_a, e->body_b, &e->inv_mass, &e->inv_inertia);
      // generalized-force map: free-joint fast path or the dof chain of each body
      p->chain = malloc(sizeof(int) * (2 * m->nv + 1));
      if (p->chain) {
        int count = 0;
        e->free_a = mjfx_free_dofadr(m, e->body_a);
        e->chain_a0 = count;
        if (e->free_a < 0) count += mjfx_dof_chain(m, e->body_a, p->chain + count);
        e->chain_a1 = count;
        e->free_b = mjfx_free_dofadr(m, e->body_b);
        e->chain_b0 = count;
        if (e->free_b < 0) count += mjfx_dof_chain(m, e->body_b, p->chain + count);
        e->chain_b1 = count;
        p->nchain = count;
        return 0;
      }
      snprintf(err, errsz, "mjflex: flexure '%.200s': out of memory", name);
    }
  }
  free_part(p);
  return -1;
}

// The reference configuration in d's kinematics, for reading elements: qpos0 and the mocap bodies at
// their model poses (what mj_resetData sets). The caller's qpos and mocap poses are saved in *saved
// (NULL: out of memory) and put back by measure_end. init runs before MuJoCo resets the data: every
// input of mj_kinematics is set here, none is read uninitialized.
static double* measure_begin(const mjModel* m, mjData* d) {
  size_t nq = (size_t)m->nq, nm = (size_t)m->nmocap;
  double* saved = malloc(sizeof(double) * (nq + 7 * nm + 1));
  if (!saved) return NULL;
  memcpy(saved, d->qpos, sizeof(double) * nq);
  memcpy(saved + nq, d->mocap_pos, sizeof(double) * 3 * nm);
  memcpy(saved + nq + 3 * nm, d->mocap_quat, sizeof(double) * 4 * nm);
  memcpy(d->qpos, m->qpos0, sizeof(double) * nq);
  for (int b = 0; b < m->nbody; b++) {
    int id = m->body_mocapid[b];
    if (id < 0 || id >= m->nmocap) continue;
    memcpy(d->mocap_pos + 3 * id, m->body_pos + 3 * b, 3 * sizeof(double));
    memcpy(d->mocap_quat + 4 * id, m->body_quat + 4 * b, 4 * sizeof(double));
  }
  mj_kinematics(m, d);
  return saved;
}

// Put back what measure_begin saved; with `kinematics`, the data's kinematics too (bit for bit).
static void measure_end(const mjModel* m, mjData* d, double* saved, int kinematics) {
  size_t nq = (size_t)m->nq, nm = (size_t)m->nmocap;
  memcpy(d->qpos, saved, sizeof(double) * nq);
  memcpy(d->mocap_pos, saved + nq, sizeof(double) * 3 * nm);
  memcpy(d->mocap_quat, saved + nq + 3 * nm, sizeof(double) * 4 * nm);
  free(saved);
  if (kinematics) mj_kinematics(m, d);
}

// Every element of m read on d (its kinematics are put back bit for bit): the table, or NULL with a
// message in err.
static Table* read_model(const mjModel* m, mjData* d, char* err, int errsz) {
  int n = count_of(m);
  Part* parts = calloc(n ? n : 1, sizeof(Part));
  int* instance = malloc(sizeof(int) * (n ? n : 1));
  double* saved = parts && instance ? measure_begin(m, d) : NULL;
  if (!saved) {
    free(parts), free(instance);
    snprintf(err, errsz, "mjflex: out of memory");
    return NULL;
  }
  int k = 0, failed = 0;
  for (int i = 0; i < m->nplugin && !failed; i++) {
    if (m->plugin[i] != g_slot) continue;
    failed = read_part(m, d, i, parts + k, err, errsz);
    instance[k++] = i;
  }
  measure_end(m, d, saved, 1);
  Table* t = failed ? NULL : gather(parts, instance, n);
  if (!failed && !t) snprintf(err, errsz, "mjflex: out of memory");
  for (int j = 0; j < k; j++) free_part(parts + j);
  free(parts), free(instance);
  return t;
}

//------------------------------------------------------------------------------ callbacks

// Sleeping: whether tree `t` may sleep: its policy lets MuJoCo put it to sleep.
static int may_sleep(const mjModel* m, int t) {
  int policy = m->tree_sleep_policy[t];
  return policy != mjSLEEP_NEVER && policy != mjSLEEP_AUTO_NEVER;
}

// With sleeping enabled, warn (once per mjData) about an element that joins a tree which may sleep to
// another tree or a mocap body: MuJoCo ignores forces on sleeping trees, and only the compiled model's
// policies count (mjflex.add_flexure and python -m mjflex convert write sleep="never" on such trees).
static void warn_sleepy(const mjModel* m, const Table* t) {
  if (!mjENABLED(mjENBL_SLEEP)) return;
  int first = -1, tree = -1, count = 0;
  for (int k = 0; k < t->n; k++) {
    int ba = t->el[k].body_a, bb = t->el[k].body_b;
    int ta = m->body_treeid[ba], tb = m->body_treeid[bb];
    int mocap = m->body_mocapid[ba] >= 0 || m->body_mocapid[bb] >= 0;
    if (ta == tb || ((ta < 0 || tb < 0) && !mocap)) continue;
    int sleepy = ta >= 0 && may_sleep(m, ta) ? ta : (tb >= 0 && may_sleep(m, tb) ? tb : -1);
    if (sleepy < 0) continue;
    if (first < 0) first = k, tree = sleepy;
    count++;
  }
  if (first < 0) return;
  const char* root = m->names + m->name_bodyadr[m->tree_bodyadr[tree]];
  mju_warning(
      "mjflex: flexure '%.200s' (and %d more) joins the tree of body '%.200s', which may sleep: sleeping is enabled, "
      "and MuJoCo ignores forces on sleeping trees, so the element's force would be lost while it sleeps. Set "
      "sleep=\"never\" on that body (mjflex.add_flexure and python -m mjflex convert write it), or disable sleeping",
      instance_name(m, t->instance[first]), count - 1, root[0] ? root : "(unnamed)");
}

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
    t = gather(s->parts, instance, s->nparts);
  }
  free(instance);
  atomic_fetch_sub(&g_live, s->nparts);
  s->counted -= s->nparts;
  free_parts(s);
  if (!t || install_table(s, m, t)) return -1;
  warn_sleepy(m, s->table);
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
  double* saved = measure_begin(m, d);
  if (!saved) return init_fail(d, "mjflex: out of memory");
  int failed = read_part(m, d, instance, s->parts + s->nparts, err, sizeof(err));
  measure_end(m, d, saved, 0);  // a fresh data: MuJoCo resets it next
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
  Table* t = read_model(m, d, err, sizeof(err));
  if (!t && !atomic_exchange(&g_warned_unread, 1)) {
    mju_warning("%s. mjflex: so the elements of model '%.100s' cannot be read for a data made from another model: "
                "its forces are NaN", err, m->names[0] ? m->names : "unnamed");
  }
  return t;
}

// The state of d holding model m's elements, reading them when d's table is another model's. NULL, with
// a warning once per model, when they cannot be read (or d cannot hold a state: *temp gets a table to free).
static State* state_for(const mjModel* m, mjData* d, Table** temp) {
  char err[1000];
  *temp = NULL;
  State* s = (State*)mjfx_states_find(d, d->buffer);
  if (!s && !data_has_instance(d)) {
    *temp = stateless_table(m, d);
    return NULL;
  }
  if (!s && !(s = state_new(d))) return NULL;
  s->state_base = (uintptr_t)d->plugin_state;
  if (s->table && key_is(&s->key, m)) {
    int i = s->table->n ? s->table->instance[0] : -1;  // the model's leader: d's own word, if d has it
    if (i >= 0 && i < d->nplugin && d->plugin[i] == g_slot && d->plugin_data[i] != (uintptr_t)s) own_words(d, s);
    return s;
  }
  if (key_is(&s->refused, m)) return NULL;
  Table* t = read_model(m, d, err, sizeof(err));
  if (t && !install_table(s, m, t)) {
    own_words(d, s);
    return s;
  }
  s->refused = key_of(m);
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
  if (v->element >= 0 && v->element < t->n) mjfx_report(m, v, instance_name(m, t->instance[v->element]));
}

static void nan_forces(const mjModel* m, mjData* d) {
  for (int i = 0; i < m->nv; i++) d->qfrc_passive[i] = NAN;  // so that MuJoCo's checks see it too
}

static void flexure_compute(const mjModel* m, mjData* d, int instance, int capability_bit) {
  if (!is_leader(m, instance)) return;
  Table* temp;
  State* s = state_for(m, d, &temp);
  if (!s) {
    if (!temp || mjfx_evaluate(m, d, temp->el, temp->n, temp->chain, temp->exps, temp->coefs, MJFX_APPLY,
                               d->qfrc_passive, NULL, NULL, NULL) >= 0) {
      nan_forces(m, d);  // no force is silently lost
    }
    free_table(temp);
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
  State* s = state_for(m, d, &temp);
  free_table(temp);
  if (!s) return;
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
// site's pose, coloured by |rotation about z| x strain_per_radian over the full scale (the rotation itself
// without strain_per_radian); where site a's group is shown, while the scene has room.
static void flexure_visualize(const mjModel* m, mjData* d, const mjvOption* opt, mjvScene* scn, int instance) {
  if (!is_leader(m, instance)) return;
  Table* temp;
  State* s = state_for(m, d, &temp);
  free_table(temp);
  if (!s || !s->table->n) return;
  Table* t = s->table;
  if (!s->twists && !(s->twists = malloc(sizeof(double) * 6 * t->n))) return;
  mjfxScan scan;
  mjfx_evaluate(m, d, t->el, t->n, t->chain, t->exps, t->coefs, MJFX_COORDS, NULL, s->twists, NULL, &scan);
  for (int k = 0; k < t->n && scn->ngeom < scn->maxgeom; k++) {
    int site = t->el[k].site_a;
    int group = m->site_group[site];
    if (!opt->sitegroup[group < 0 ? 0 : (group >= mjNGROUP ? mjNGROUP - 1 : group)]) continue;
    double per_radian = t->strain[2 * k], scale = t->strain[2 * k + 1];
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
    if (opt->label == mjLABEL_SITE) snprintf(g->label, sizeof(g->label), "%s", instance_name(m, t->instance[k]));
    scn->ngeom++;
  }
}

//------------------------------------------------------------------------------ for Python (ctypes)

// The element table row of instance `instance` in d (what Flexures builds from the config), or -1 when
// the instance is not the plugin's, or d holds no table of model m.
int mjfx_plugin_element(const mjModel* m, const mjData* d, int instance, mjfxElement* out) {
  if (!is_ours(m, instance)) return -1;
  const State* s = (const State*)mjfx_states_find(d, d->buffer);
  if (!s || !s->table || !key_is(&s->key, m)) return -1;
  for (int k = 0; k < s->table->n; k++) {
    if (s->table->instance[k] == instance) {
      *out = s->table->el[k];
      return 0;
    }
  }
  return -1;
}

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
  mjpPlugin plugin;
  mjp_defaultPlugin(&plugin);
  plugin.name = MJFX_PLUGIN_NAME;
  plugin.capabilityflags |= mjPLUGIN_PASSIVE;
  plugin.nattribute = MJFX_NATTRIBUTE;
  plugin.attributes = MJFX_ATTRIBUTES;
  plugin.nstate = flexure_nstate;
  plugin.init = flexure_init;
  plugin.destroy = flexure_destroy;
  plugin.copy = flexure_copy;
  plugin.reset = flexure_reset;
  plugin.compute = flexure_compute;
  plugin.advance = flexure_advance;
  plugin.visualize = flexure_visualize;
  g_slot = mjp_registerPlugin(&plugin);
  g_status = 1;
}
