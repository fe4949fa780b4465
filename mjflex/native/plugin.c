// The engine plugin mjflex.flexure (capability mjPLUGIN_PASSIVE): one instance per element.
//
// init parses and validates the instance's configuration (config.c) and measures the rest
// offset at qpos0; a bad value is mju_warning + return -1, which MuJoCo turns into a compile
// error naming the element. compute adds the element's generalized forces to qfrc_passive.
// All mutable state lives in plugin_data (per mjData); nothing is global but the plugin struct.
//
// The first instance of the plugin in a model (the leader) does the per-step work of all: the
// last instance's init gathers every instance's element into one contiguous table of the
// leader's (what the mjcb_passive dispatcher evaluates for text records: the same loop), and the
// other instances' compute returns at once. MuJoCo's own loops over plugin instances still cost
// a few hundred instructions per instance and step.
//
// Divergence (see elements.h, mjfx_watch_*): the leader owns the mjData's watch. Its compute
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

// All elements of a model, gathered (the leader's).
typedef struct Table_ {
  int n;
  mjfxElement* el;
  int* chain;
  int* exps;
  double* coefs;
  int* instance;  // plugin instance of each element
} Table;

typedef struct Instance_ {
  mjfxElement el;
  int* chain;     // dofs moving body A, then body B (chain_a0.. in el)
  int* exps;      // own terms
  double* coefs;
  int nchain, nterms;
  int leader;     // instance id of the model's first mjflex.flexure instance
  mjfxWatch* watch;  // the mjData's watch, tallies by element of the table (leader only)
  Table* table;      // every element (leader only, from the last instance's init on)
  double strain_per_radian;  // 0: not given (the colour shows the rotation about z)
  double strain_scale;       // full scale of the colour (0: the default, MJFX_DEFAULT_*_SCALE)
  double* twists;            // 6 per element of the table, for visualize (leader only, allocated on first use)
  const mjModel* model;      // the model init read the element from, and its configuration strings: a data
  const char* attr;          //   stepped with another model reads its elements again (see leader_for)
} Instance;

static const char* instance_name(const mjModel* m, int instance) {
  return m->names + m->name_pluginadr[instance];
}

static void free_table(Table* t) {
  if (!t) return;
  free(t->el);
  free(t->chain);
  free(t->exps);
  free(t->coefs);
  free(t->instance);
  free(t);
}

// instances alive in the process (a test checks that failed compiles leave none behind)
static _Atomic long g_live = 0;

long mjfx_live_instances(void) {
  return atomic_load(&g_live);
}

static void free_instance(Instance* in) {
  if (!in) return;
  atomic_fetch_sub(&g_live, 1);
  free(in->chain);
  free(in->exps);
  free(in->coefs);
  free(in->watch);
  free(in->twists);
  free_table(in->table);
  free(in);
}

static int leader_of(const mjModel* m, int instance) {
  for (int i = 0; i < m->nplugin; i++) {
    if (m->plugin[i] == m->plugin[instance]) return i;
  }
  return instance;
}

static int last_of(const mjModel* m, int instance) {
  for (int i = m->nplugin - 1; i >= 0; i--) {
    if (m->plugin[i] == m->plugin[instance]) return i;
  }
  return instance;
}

// Gather the elements of every instance (all initialized: this runs in the last one's init) into
// the leader's table, with the chain and term ranges shifted into the concatenated arrays.
static Table* gather(const mjModel* m, const mjData* d, int leader, int last) {
  Table* t = calloc(1, sizeof(Table));
  if (!t) return NULL;
  int n = 0, nchain = 0, nterms = 0;
  for (int i = leader; i <= last; i++) {
    const Instance* in = m->plugin[i] == m->plugin[leader] ? (const Instance*)d->plugin_data[i] : NULL;
    if (in) n++, nchain += in->nchain, nterms += in->nterms;
  }
  t->el = malloc(sizeof(mjfxElement) * (n ? n : 1));
  t->instance = malloc(sizeof(int) * (n ? n : 1));
  t->chain = malloc(sizeof(int) * (nchain ? nchain : 1));
  t->exps = calloc((size_t)(nterms ? nterms : 1) * MJFX_TERM_COLUMNS, sizeof(int));
  t->coefs = calloc(nterms ? nterms : 1, sizeof(double));
  if (!t->el || !t->instance || !t->chain || !t->exps || !t->coefs) {
    free_table(t);
    return NULL;
  }
  int k = 0, c = 0, r = 0;
  for (int i = leader; i <= last; i++) {
    const Instance* in = m->plugin[i] == m->plugin[leader] ? (const Instance*)d->plugin_data[i] : NULL;
    if (!in) continue;
    mjfxElement* e = t->el + k;
    *e = in->el;
    e->chain_a0 += c, e->chain_a1 += c, e->chain_b0 += c, e->chain_b1 += c;
    e->terms_lo += r, e->terms_hi += r;
    memcpy(t->chain + c, in->chain, sizeof(int) * in->nchain);
    if (in->nterms) {
      memcpy(t->exps + MJFX_TERM_COLUMNS * r, in->exps, sizeof(int) * MJFX_TERM_COLUMNS * in->nterms);
      memcpy(t->coefs + r, in->coefs, sizeof(double) * in->nterms);
    }
    t->instance[k] = i;
    c += in->nchain, r += in->nterms, k++;
  }
  t->n = n;
  return t;
}

// A failed init: report, free this instance (MuJoCo calls no destroy for it), and free the earlier
// instances of the plugin in d too, their pointers zeroed: MuJoCo 4.0.0 destroys the instances it had
// initialized (observed: tests/test_plugin_config.py counts live instances), the 3.x source frees the
// mjData without destroying them; either way nothing leaks and nothing is freed twice.
static int init_fail(const mjModel* m, mjData* d, int instance, Instance* in, const char* msg) {
  mju_warning("%s", msg);
  free_instance(in);
  for (int i = 0; i < instance; i++) {
    if (m->plugin[i] == m->plugin[instance] && d->plugin_data[i]) {
      free_instance((Instance*)d->plugin_data[i]);
      d->plugin_data[i] = 0;
    }
  }
  return -1;
}

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
  if (dist > tol || angle > MJFX_COINCIDENCE_ANGLE) {
    snprintf(err, errsz,
             "mjflex: flexure '%.200s' (plugin instance of %s): its frame is %.3g m and %.3g rad away from the site "
             "'%.200s' its site attribute names (at qpos0). The site was moved without the element: place the "
             "element again at the site (mjflex.add_flexure(..., site=...) or mjflex.make_compliant), or drop the "
             "site attribute", name, MJFX_PLUGIN_NAME, dist, angle, value);
    return -1;
  }
  return 0;
}

// Whether tree `t` may sleep: its policy lets MuJoCo put it to sleep.
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

static int flexure_init(const mjModel* m, mjData* d, int instance) {
  char err[1000];
  const char* name = instance_name(m, instance);
  Instance* in = calloc(1, sizeof(Instance));
  if (!in) return init_fail(m, d, instance, NULL, "mjflex: out of memory");
  atomic_fetch_add(&g_live, 1);
  if (!name[0]) {
    snprintf(err, sizeof(err),
             "mjflex: an instance of plugin %s (instance %d) has no name; an element is known by its name: declare it "
             "as <instance name=\"...\"> under <extension><plugin plugin=\"%s\">",
             MJFX_PLUGIN_NAME, instance, MJFX_PLUGIN_NAME);
    return init_fail(m, d, instance, in, err);
  }
  const char* values[MJFX_NATTRIBUTE];
  for (int i = 0; i < MJFX_NATTRIBUTE; i++) {
    values[i] = mj_getPluginConfig(m, instance, MJFX_ATTRIBUTES[i]);
    if (!values[i]) values[i] = "";
  }
  mjfxParsed parsed;
  memset(&parsed, 0, sizeof(parsed));
  if (mjfx_parse_config(name, values, &parsed, err, sizeof(err))) return init_fail(m, d, instance, in, err);
  in->el = parsed.el;
  in->exps = parsed.exps, in->coefs = parsed.coefs, in->nterms = parsed.nterms;
  in->strain_per_radian = parsed.strain_per_radian, in->strain_scale = parsed.strain_scale;
  mjfxElement* e = &in->el;

  const char* record = record_of(m, name);
  if (record) {
    snprintf(err, sizeof(err),
             "mjflex: flexure '%.200s' is both a plugin instance and the text record '%.200s': its forces would be "
             "added twice. Keep one of them (python -m mjflex convert writes either form)",
             name, record);
    return init_fail(m, d, instance, in, err);
  }
  int sites[2];
  for (int k = 0; k < 2; k++) {
    const char* key = k ? "site_b" : "site_a";
    const char* site = values[k];
    if (!site[0]) {
      snprintf(err, sizeof(err),
               "mjflex: flexure '%.200s' (plugin instance of %s): %s is missing. Add <config key=\"%s\" "
               "value=\"SITE\"/> naming the site of the element frame on body %s",
               name, MJFX_PLUGIN_NAME, key, key, k ? "B" : "A");
      return init_fail(m, d, instance, in, err);
    }
    sites[k] = config_site(m, name, site);
    if (sites[k] < 0) {
      snprintf(err, sizeof(err),
               "mjflex: flexure '%.200s' (plugin instance of %s): %s '%.200s' is not a site of the model. Add <site "
               "name=\"%.200s\"/> at the element frame (body %s) or fix the name",
               name, MJFX_PLUGIN_NAME, key, site, site, k ? "B" : "A");
      return init_fail(m, d, instance, in, err);
    }
  }
  e->site_a = sites[0], e->site_b = sites[1];
  e->body_a = m->site_bodyid[sites[0]], e->body_b = m->site_bodyid[sites[1]];
  if (e->body_a == e->body_b) {
    snprintf(err, sizeof(err),
             "mjflex: flexure '%.200s' (plugin instance of %s): both sites are on body '%.200s'. Put site_a on one "
             "body and site_b on the other (a site of the world body grounds the element)",
             name, MJFX_PLUGIN_NAME, m->names + m->name_bodyadr[e->body_a]);
    return init_fail(m, d, instance, in, err);
  }

  // rest offset at qpos0 (round-off of the model file absorbed), as Python's tables measure it
  int moved = memcmp(d->qpos, m->qpos0, sizeof(mjtNum) * m->nq) != 0;
  mjtNum* saved = NULL;
  if (moved) {
    saved = malloc(sizeof(mjtNum) * (m->nq ? m->nq : 1));
    if (!saved) return init_fail(m, d, instance, in, "mjflex: out of memory");
    memcpy(saved, d->qpos, sizeof(mjtNum) * m->nq);
    memcpy(d->qpos, m->qpos0, sizeof(mjtNum) * m->nq);
  }
  mj_kinematics(m, d);
  double dist, angle;
  mjfx_rest_offset(d, e->site_a, e->site_b, e->R0, e->p0, &dist, &angle);
  if (moved) {
    memcpy(d->qpos, saved, sizeof(mjtNum) * m->nq);
    free(saved);
  }
  double scale = mjfx_length_scale(m, e->site_a, e->site_b);
  double tol = MJFX_COINCIDENCE_RTOL * (scale > 1e-9 ? scale : 1e-9);
  if (dist > tol || angle > MJFX_COINCIDENCE_ANGLE) {
    snprintf(err, sizeof(err),
             "mjflex: flexure '%.200s' (plugin instance of %s): sites '%.100s' and '%.100s' are %.3g m apart and "
             "%.3g rad apart at qpos0 (tolerance %.3g m: %g times the %.3g m of site and body positions that place "
             "them, which covers their 6-digit rounding in saved files; %g rad). Both frames must coincide in the "
             "reference configuration: place both at the same world pose",
             name, MJFX_PLUGIN_NAME, values[0], values[1], dist, angle, tol, MJFX_COINCIDENCE_RTOL, scale,
             MJFX_COINCIDENCE_ANGLE);
    return init_fail(m, d, instance, in, err);
  }
  if (check_frame_site(m, d, name, values[MJFX_NATTRIBUTE - 1], e->site_a, tol, err, sizeof(err))) {
    return init_fail(m, d, instance, in, err);
  }
  mjfx_element_prepare(m, e);
  mjfx_inverse_inertia(m, e->body_a, e->body_b, &e->inv_mass, &e->inv_inertia);

  // generalized-force map: free-joint fast path or the dof chain of each body
  in->chain = malloc(sizeof(int) * (2 * m->nv + 1));
  if (!in->chain) return init_fail(m, d, instance, in, "mjflex: out of memory");
  int count = 0;
  e->free_a = mjfx_free_dofadr(m, e->body_a);
  e->chain_a0 = count;
  if (e->free_a < 0) count += mjfx_dof_chain(m, e->body_a, in->chain + count);
  e->chain_a1 = count;
  e->free_b = mjfx_free_dofadr(m, e->body_b);
  e->chain_b0 = count;
  if (e->free_b < 0) count += mjfx_dof_chain(m, e->body_b, in->chain + count);
  e->chain_b1 = count;
  in->nchain = count;

  in->model = m, in->attr = m->plugin_attr;
  in->leader = leader_of(m, instance);
  if (in->leader == instance) {
    in->watch = malloc(mjfx_watch_size(m->nplugin));
    if (!in->watch) return init_fail(m, d, instance, in, "mjflex: out of memory");
    in->watch->exact = 1;
    mjfx_watch_clear(in->watch, m->nplugin);
  }
  d->plugin_data[instance] = (uintptr_t)in;
  if (last_of(m, instance) == instance) {  // every instance is initialized: the leader takes over the work
    Instance* leader = (Instance*)d->plugin_data[in->leader];
    leader->table = gather(m, d, in->leader, instance);
    if (!leader->table) {
      d->plugin_data[instance] = 0;
      return init_fail(m, d, instance, in, "mjflex: out of memory");
    }
    mjfx_watch_clear(leader->watch, leader->table->n);
    warn_sleepy(m, leader->table);
  }
  return 0;
}

static void flexure_destroy(mjData* d, int instance) {
  free_instance((Instance*)d->plugin_data[instance]);
  d->plugin_data[instance] = 0;
}

static void flexure_copy(mjData* dest, const mjModel* m, const mjData* src, int instance) {
  Instance* to = (Instance*)dest->plugin_data[instance];
  const Instance* from = (const Instance*)src->plugin_data[instance];
  if (to && from && to->watch && from->watch && to->watch->n == from->watch->n && to->table) {
    memcpy(to->watch, from->watch, mjfx_watch_size(from->watch->n));  // the copy continues the run
  }
}

static void flexure_reset(const mjModel* m, mjtNum* plugin_state, void* plugin_data, int instance) {
  Instance* in = (Instance*)plugin_data;
  if (in && in->watch) in->watch->reset = 1;  // a new run, unless MuJoCo counts a bad state (its auto-reset)
}

static void report(const mjModel* m, const Table* t, const mjfxVerdict* v) {
  if (v->element >= 0 && v->element < t->n) mjfx_report(m, v, instance_name(m, t->instance[v->element]));
}

// The elements of d again, read from model m as init read them from the model d was made for: d is
// stepped with another model object (mujoco.batch.Batch.set_models, or a copy of the model with other
// parameters or geometry). The run's divergence tallies carry over. Init measures the rest offsets at
// qpos0 in d, so d's kinematics are computed again afterwards (bit for bit what they were). NULL, with
// a warning, where the elements cannot be read (then qfrc_passive gets NaN: no force is silently lost).
static Instance* reread(const mjModel* m, mjData* d, int leader) {
  Instance* old = (Instance*)d->plugin_data[leader];
  mjfxWatch* watch = old->watch;
  old->watch = NULL;
  int last = last_of(m, leader);
  for (int i = leader; i <= last; i++) {
    if (m->plugin[i] != m->plugin[leader] || !d->plugin_data[i]) continue;
    free_instance((Instance*)d->plugin_data[i]);
    d->plugin_data[i] = 0;
  }
  int failed = 0;
  for (int i = leader; i <= last && !failed; i++) {
    if (m->plugin[i] == m->plugin[leader]) failed = flexure_init(m, d, i) != 0;
  }
  mj_kinematics(m, d);
  Instance* in = failed ? NULL : (Instance*)d->plugin_data[leader];
  if (in && in->watch && watch && in->watch->n == watch->n) memcpy(in->watch, watch, mjfx_watch_size(watch->n));
  free(watch);
  if (!in) {
    mju_warning("mjflex: the elements of a data stepped with another model than its own could not be read from that "
                "model (see the message above); make the data from the model you step it with (mujoco.MjData(model))");
  }
  return in;
}

// The leader's instance for model m (NULL for the other instances: the leader computes every element).
static Instance* leader_for(const mjModel* m, mjData* d, int instance) {
  Instance* in = (Instance*)d->plugin_data[instance];
  if (!in || !in->table) return NULL;
  if (in->model == m && in->attr == m->plugin_attr) return in;
  return reread(m, d, instance);
}

static void flexure_compute(const mjModel* m, mjData* d, int instance, int capability_bit) {
  Instance* in = leader_for(m, d, instance);
  if (!in) {
    if (d->plugin_data[instance] == 0 && instance == leader_of(m, instance)) {  // reread failed: no silent zero
      for (int i = 0; i < m->nv; i++) d->qfrc_passive[i] = NAN;
    }
    return;
  }
  Table* t = in->table;
  mjfxVerdict v;
  mjfx_watch_judge(in->watch, m, d, 1, &v);
  report(m, t, &v);
  mjfxScan scan;
  int bad = mjfx_evaluate(m, d, t->el, t->n, t->chain, t->exps, t->coefs, MJFX_APPLY, d->qfrc_passive, NULL, NULL,
                          &scan);
  if (bad >= 0) {
    for (int i = 0; i < m->nv; i++) d->qfrc_passive[i] = NAN;  // so that MuJoCo's checks see it too
  }
  mjfx_watch_record(in->watch, m, d, &scan, 1, &v);
  report(m, t, &v);
}

static void flexure_advance(const mjModel* m, mjData* d, int instance) {
  Instance* in = leader_for(m, d, instance);
  if (!in) return;
  mjfxVerdict v;
  mjfx_watch_judge(in->watch, m, d, 1, &v);
  mjfx_watch_step_end(in->watch, d);
  report(m, in->table, &v);
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
  Instance* in = leader_for(m, d, instance);
  if (!in || !in->table->n) return;
  Table* t = in->table;
  if (!in->twists && !(in->twists = malloc(sizeof(double) * 6 * t->n))) return;
  mjfxScan scan;
  mjfx_evaluate(m, d, t->el, t->n, t->chain, t->exps, t->coefs, MJFX_COORDS, NULL, in->twists, NULL, &scan);
  for (int k = 0; k < t->n && scn->ngeom < scn->maxgeom; k++) {
    int site = t->el[k].site_a;
    int group = m->site_group[site];
    if (!opt->sitegroup[group < 0 ? 0 : (group >= mjNGROUP ? mjNGROUP - 1 : group)]) continue;
    const Instance* own = (const Instance*)d->plugin_data[t->instance[k]];
    double bending = fabs(in->twists[6 * k + 2]);
    double value = own->strain_per_radian > 0 ? bending * own->strain_per_radian : bending;
    double full = own->strain_scale > 0 ? own->strain_scale
                                        : (own->strain_per_radian > 0 ? MJFX_DEFAULT_STRAIN_SCALE
                                                                      : MJFX_DEFAULT_ROTATION_SCALE);
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

// The element table row of instance `instance` in d (what Flexures builds from the config), or
// -1 when the instance is not ours or not initialized.
int mjfx_plugin_element(const mjModel* m, const mjData* d, int instance, mjfxElement* out) {
  if (instance < 0 || instance >= m->nplugin || !d->plugin_data[instance]) return -1;
  const mjpPlugin* p = mjp_getPluginAtSlot(m->plugin[instance]);
  if (!p || strcmp(p->name, MJFX_PLUGIN_NAME)) return -1;
  *out = ((const Instance*)d->plugin_data[instance])->el;
  return 0;
}

// The divergence watch of d (tallies indexed by plugin instance), or NULL.
const mjfxWatch* mjfx_plugin_watch(const mjModel* m, const mjData* d) {
  for (int i = 0; i < m->nplugin; i++) {
    const mjpPlugin* p = mjp_getPluginAtSlot(m->plugin[i]);
    if (p && !strcmp(p->name, MJFX_PLUGIN_NAME)) {
      const Instance* in = (const Instance*)d->plugin_data[i];
      return in ? in->watch : NULL;
    }
  }
  return NULL;
}

//------------------------------------------------------------------------------ registration

// The MuJoCo version whose headers this was compiled against (a test builds a copy that claims another).
#ifndef MJFX_HEADER_VERSION
#define MJFX_HEADER_VERSION mjVERSION_HEADER
#endif

// 0 until registration ran: 1 registered, -1 refused (header and library versions differ)
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
  mjp_registerPlugin(&plugin);
  g_status = 1;
}
