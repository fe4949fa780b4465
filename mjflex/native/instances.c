// Reading elements from a model, both forms (see instances.h).

#include "instances.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "config.h"

const char* mjfx_instance_name(const mjModel* m, int instance) {
  return m->names + m->name_pluginadr[instance];
}

// The plugin's registered slot (-1 until registration; compute never runs before it).
static int g_slot = -1;

int mjfx_plugin_slot(void) {
  return g_slot;
}

void mjfx_set_plugin_slot(int slot) {
  g_slot = slot;
}

void mjfx_free_part(Part* p) {
  free(p->chain);
  free(p->exps);
  free(p->coefs);
  mjfx_free_values(&p->values);
  memset(p, 0, sizeof(Part));
}

void mjfx_free_table(Table* t) {
  if (!t) return;
  for (int k = 0; t->values && k < t->n; k++) mjfx_free_values(t->values + k);
  free(t->el);
  free(t->chain);
  free(t->exps);
  free(t->coefs);
  free(t->instance);
  free(t->values);
  free(t);
}

// Gather parts (in instance order) into one table, the chain and term ranges shifted into the
// concatenated arrays. NULL: out of memory.
Table* mjfx_gather(Part* parts, const int* instance, int n, int values) {
  Table* t = calloc(1, sizeof(Table));
  if (!t) return NULL;
  int nchain = 0, nterms = 0;
  for (int k = 0; k < n; k++) nchain += parts[k].nchain, nterms += parts[k].nterms;
  t->el = malloc(sizeof(mjfxElement) * (n ? n : 1));
  t->instance = malloc(sizeof(int) * (n ? n : 1));
  t->values = values ? calloc(n ? n : 1, sizeof(mjfxValues)) : NULL;
  t->chain = malloc(sizeof(int) * (nchain ? nchain : 1));
  t->exps = calloc((size_t)(nterms ? nterms : 1) * MJFX_TERM_COLUMNS, sizeof(int));
  t->coefs = calloc(nterms ? nterms : 1, sizeof(double));
  if (!t->el || !t->instance || (values && !t->values) || !t->chain || !t->exps || !t->coefs) {
    mjfx_free_table(t);
    return NULL;
  }
  int c = 0, r = 0;
  for (int k = 0; k < n; k++) {
    Part* p = parts + k;
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
    if (values) t->values[k] = p->values, memset(&p->values, 0, sizeof(mjfxValues));  // moved
    c += p->nchain, r += p->nterms;
  }
  t->n = n, t->nchain = nchain, t->nterms = nterms;
  return t;
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

// Whether the sites P + values[k] + S exist (P, S: the first pre and last suf characters of element); their ids.
static int sites_under(const mjModel* m, const char* element, int pre, int suf, const char* const* values, int n,
                       int* ids) {
  int nlen = (int)strlen(element);
  char name[2048];
  for (int k = 0; k < n; k++) {
    ids[k] = -1;
    if (!values[k][0]) continue;
    int len = snprintf(name, sizeof(name), "%.*s%s%s", pre, element, values[k], element + nlen - suf);
    if (len >= (int)sizeof(name) || (ids[k] = mj_name2id(m, mjOBJ_SITE, name)) < 0) return 0;
  }
  return 1;
}

// The ids of the sites an element's configuration names (values[k], "" for none: id -1), in one rule with
// mjflex.mjcf.config.attached_names: the names themselves when all exist (mjflex.attach writes the attached names);
// else, for a configuration written by mjflex 1.0's attach (names as the child wrote them), P + value + S for the
// affix of the element's name P + E + S (E not empty) under which all exist, the longest P + S first, then the
// longest P. 0, or -1 when no affix binds them all.
static int config_site_ids(const mjModel* m, const char* element, const char* const* values, int n, int* ids) {
  if (sites_under(m, element, 0, 0, values, n, ids)) return 0;
  for (int total = (int)strlen(element) - 1; total > 0; total--) {
    for (int pre = total; pre >= 0; pre--) {
      if (sites_under(m, element, pre, total - pre, values, n, ids)) return 0;
    }
  }
  return -1;
}

// The value of attribute row as given (white space around it left out: its span in v) into out.
static const char* value_text(const char* const* values, const mjfxValues* v, int row, char* out, int size) {
  int len = v->count[row] < 0 ? 0 : v->count[row];
  snprintf(out, size, "%.*s", len, values[row] + (len ? v->first[row] : 0));
  return out;
}

// Whether a distance and an angle are within the coincidence tolerances; NaN is not (a NaN or
// infinite position or orientation in the model would otherwise pass: NaN > tol is false).
static int coincide(double dist, double angle, double tol) {
  return dist <= tol && angle <= MJFX_COINCIDENCE_ANGLE;
}

double mjfx_coincidence_tolerance(const mjModel* m, int sa, int sb) {
  double scale = mjfx_length_scale(m, sa, sb);
  return MJFX_COINCIDENCE_RTOL * (scale > 1e-9 ? scale : 1e-9);
}

int mjfx_offsets_coincide(const mjModel* m, const mjfxElement* a, const mjfxElement* b, double gap[2]) {
  double R[9], p[3];
  mjfx_relative_offset(a->R0, a->p0, b->R0, b->p0, R, p, gap, gap + 1);
  return coincide(gap[0], gap[1], mjfx_coincidence_tolerance(m, a->site_a, a->site_b));
}

static const char NONFINITE[] =
    "Their pose at qpos0 is not finite: a position, orientation or joint reference (qpos0) that places them "
    "is NaN or infinite; give finite numbers";

// How the messages about an element's sites speak of them, in the words of its form (MJFX_FORM_*).
static const struct {
  const char* site[2];   // the two sites
  const char* names;     // "... the frame site S" that the element names
  const char* drop;      // how to drop that frame site
  const char* drop_if;   // when to drop it
} WORDS[2] = {
    {{"site_a", "site_b"}, "its site attribute names", "drop the site attribute", "if site_a and site_b are right"},
    {{"site a", "site b"}, "its record names", "drop \"site\" from its record", "if the element's own sites are right"},
};

// The optional frame site (attribute "site", written by add_flexure(..., site=...)): it must exist and
// coincide with frame a at qpos0 (d holds the kinematics at qpos0). Returns 0 or -1 with a message.
static int check_frame_site(const mjModel* m, const mjData* d, const char* name, int form, const char* value,
                            int id, int site_a, double tol, char* err, int errsz) {
  if (!value[0]) return 0;
  char head[300];
  mjfx_element_head(name, form, head, sizeof(head));
  if (id < 0) {
    snprintf(err, errsz, "%s%s the frame site '%.200s', which the model does not have. Restore the site, or %s %s",
             head, WORDS[form].names, value, WORDS[form].drop, WORDS[form].drop_if);
    return -1;
  }
  double R[9], p[3], dist, angle;
  mjfx_rest_offset(d, id, site_a, R, p, &dist, &angle);
  if (!coincide(dist, angle, tol)) {
    snprintf(err, errsz,
             "%sits frame is %.3g m and %.3g rad away from the site '%.200s' %s (at qpos0). %s%s", head, dist, angle,
             value, WORDS[form].names,
             isfinite(dist) && isfinite(angle)
                 ? "The site was moved without the element: place the element again at the site "
                   "(mjflex.add_flexure(..., site=...) or mjflex.make_compliant), or "
                 : NONFINITE,
             isfinite(dist) && isfinite(angle) ? WORDS[form].drop : "");
    return -1;
  }
  return 0;
}

// the sites of an element (config_site_ids): its two sites into sites[0..1], its frame site into sites[2] (-1:
// none given, or none of that name: check_frame_site says so); 0 or -1 with a message
static int read_sites(const mjModel* m, const char* name, int form, const char* const* values, const mjfxValues* v,
                      int sites[3], char* err, int errsz) {
  char head[300], text[3][1000];
  const char* named[3];
  mjfx_element_head(name, form, head, sizeof(head));
  for (int k = 0; k < 3; k++) named[k] = value_text(values, v, k < 2 ? MJFX_A_SITE_A + k : MJFX_A_SITE, text[k], 1000);
  for (int k = 0; k < 2; k++) {
    if (!named[k][0]) {
      snprintf(err, errsz,
               "%s%s is missing. Add <config key=\"%s\" value=\"SITE\"/> naming the site of the element frame on "
               "body %s", head, WORDS[form].site[k], WORDS[form].site[k], k ? "B" : "A");
      return -1;
    }
  }
  if (!config_site_ids(m, name, named, 3, sites)) {
    // all found (a frame site not given: -1)
  } else if (!config_site_ids(m, name, named, 2, sites)) {
    // the frame site alone (a record's is written as in the record: under the element's affix); none: -1, and
    // check_frame_site says so
    if (config_site_ids(m, name, named + 2, 1, sites + 2)) sites[2] = -1;
  } else {
    int k = mj_name2id(m, mjOBJ_SITE, named[0]) < 0 ? 0 : 1;
    snprintf(err, errsz,
             "%s%s '%.200s' is not a site of the model. Add <site name=\"%.200s\"/> at the element frame (body %s) "
             "or fix the name", head, WORDS[form].site[k], named[k], named[k], k ? "B" : "A");
    return -1;
  }
  if (m->site_bodyid[sites[0]] == m->site_bodyid[sites[1]]) {
    snprintf(err, errsz,
             "%sboth sites are on body '%.200s'. Put %s on one body and %s on the other (a site of the world body "
             "grounds the element)", head, m->names + m->name_bodyadr[m->site_bodyid[sites[0]]],
             WORDS[form].site[0], WORDS[form].site[1]);
    return -1;
  }
  return 0;
}

// The rest offset of the sites (d holds the kinematics of the reference configuration): it must be the
// identity within the coincidence tolerance. 0 or -1 with a message.
static int read_rest_offset(const mjModel* m, const mjData* d, const char* name, int form,
                            const char* const* values, const mjfxValues* v, mjfxElement* e, int frame, char* err,
                            int errsz) {
  double dist, angle;
  mjfx_rest_offset(d, e->site_a, e->site_b, e->R0, e->p0, &dist, &angle);
  double scale = mjfx_length_scale(m, e->site_a, e->site_b);
  double tol = mjfx_coincidence_tolerance(m, e->site_a, e->site_b);
  if (!coincide(dist, angle, tol)) {
    char head[300];
    mjfx_element_head(name, form, head, sizeof(head));
    int finite = isfinite(dist) && isfinite(angle) && isfinite(scale);
    snprintf(err, errsz,
             "%ssites '%.100s' and '%.100s' are %.3g m apart and %.3g rad apart at qpos0 (tolerance %.3g m: %g times "
             "the %.3g m of site and body positions that place them, which covers their 6-digit rounding in saved "
             "files; %g rad). %s", head, m->names + m->name_siteadr[e->site_a], m->names + m->name_siteadr[e->site_b],
             dist, angle, tol, MJFX_COINCIDENCE_RTOL, scale,
             MJFX_COINCIDENCE_ANGLE,
             finite ? "Both frames must coincide in the reference configuration: place both at the same world pose "
                      "(mjflex.add_flexure does this)"
                    : NONFINITE);
    return -1;
  }
  char site[1000];
  return check_frame_site(m, d, name, form, value_text(values, v, MJFX_A_SITE, site, sizeof(site)), frame,
                          e->site_a, tol, err, errsz);
}

int mjfx_read_element(const mjModel* m, const mjData* d, const char* name, int form, const char* const* values,
                      Part* p, int keep, char* err, int errsz) {
  memset(p, 0, sizeof(Part));
  mjfxParsed parsed;
  if (mjfx_parse_config(name, form, values, &parsed, err, errsz)) return -1;
  p->el = parsed.el;
  p->exps = parsed.exps, p->coefs = parsed.coefs, p->nterms = parsed.nterms;
  p->values = parsed.values;
  mjfxElement* e = &p->el;
  const char* record = form == MJFX_FORM_PLUGIN ? record_of(m, name) : NULL;
  int sites[3];
  if (record) {
    snprintf(err, errsz,
             "mjflex: flexure '%.200s' is both a plugin instance and the text record '%.200s': its forces would be "
             "added twice. Keep one of them (python -m mjflex convert writes either form)",
             name, record);
  } else if (!read_sites(m, name, form, values, &p->values, sites, err, errsz)) {
    e->site_a = sites[0], e->site_b = sites[1];
    e->body_a = m->site_bodyid[sites[0]], e->body_b = m->site_bodyid[sites[1]];
    if (!read_rest_offset(m, d, name, form, values, &p->values, e, sites[2], err, errsz)) {
      e->rest = parsed.has_rest;
      if (e->rest) mjfx_compose_rest(parsed.rest_pos, parsed.rest_quat, e->R0, e->p0);
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
        if (!keep) mjfx_free_values(&p->values);
        return 0;
      }
      snprintf(err, errsz, "mjflex: flexure '%.200s': out of memory", name);
    }
  }
  mjfx_free_part(p);
  return -1;
}

// Read instance `instance` of m into p, d holding the kinematics of the reference configuration
// (measure_begin). 0, or -1 with a message in err (p holds nothing then).
int mjfx_read_part(const mjModel* m, const mjData* d, int instance, Part* p, int keep, char* err, int errsz) {
  memset(p, 0, sizeof(Part));
  const char* name = mjfx_instance_name(m, instance);
  if (!name[0]) {
    snprintf(err, errsz,
             "mjflex: an instance of plugin %s (instance %d) has no name; an element is known by its name: declare it "
             "as <instance name=\"...\"> under <extension><plugin plugin=\"%s\">",
             MJFX_PLUGIN_NAME, instance, MJFX_PLUGIN_NAME);
    return -1;
  }
  const char* values[MJFX_NATTRIBUTE];
  for (int i = 0; i < MJFX_NATTRIBUTE; i++) {
    values[i] = mj_getPluginConfig(m, instance, MJFX_SCHEMA[i].key);
    if (!values[i]) values[i] = "";
  }
  return mjfx_read_element(m, d, name, MJFX_FORM_PLUGIN, values, p, keep, err, errsz);
}

// The reference configuration in d's kinematics, for reading elements: qpos0 and the mocap bodies at
// their model poses (what mj_resetData sets). The caller's qpos and mocap poses are saved in *saved
// (NULL: out of memory) and put back by measure_end. init runs before MuJoCo resets the data: every
// input of mj_kinematics is set here, none is read uninitialized.
double* mjfx_measure_begin(const mjModel* m, mjData* d) {
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
void mjfx_measure_end(const mjModel* m, mjData* d, double* saved, int kinematics) {
  size_t nq = (size_t)m->nq, nm = (size_t)m->nmocap;
  memcpy(d->qpos, saved, sizeof(double) * nq);
  memcpy(d->mocap_pos, saved + nq, sizeof(double) * 3 * nm);
  memcpy(d->mocap_quat, saved + nq + 3 * nm, sizeof(double) * 4 * nm);
  free(saved);
  if (kinematics) mj_kinematics(m, d);
}

// Every element of m read on d (its kinematics are put back bit for bit): nrec text records first (names[k],
// values[k * MJFX_NATTRIBUTE ...]), then every instance of the plugin at `slot` (-1: none) in order. The table,
// or NULL with a message in err.
static Table* read_elements(const mjModel* m, mjData* d, int slot, int nrec, const char* const* names,
                            const char* const* values, int keep, char* err, int errsz) {
  int n = nrec;
  for (int i = 0; i < m->nplugin && slot >= 0; i++) n += m->plugin[i] == slot;
  Part* parts = calloc(n ? n : 1, sizeof(Part));
  int* instance = malloc(sizeof(int) * (n ? n : 1));
  double* saved = parts && instance ? mjfx_measure_begin(m, d) : NULL;
  if (!saved) {
    free(parts), free(instance);
    snprintf(err, errsz, "mjflex: out of memory");
    return NULL;
  }
  int k = 0, failed = 0;
  for (int r = 0; r < nrec && !failed; r++) {
    failed = mjfx_read_element(m, d, names[r], MJFX_FORM_RECORD, values + (size_t)r * MJFX_NATTRIBUTE, parts + k,
                               keep, err, errsz);
    instance[k++] = -1;
  }
  for (int i = 0; i < m->nplugin && slot >= 0 && !failed; i++) {
    if (m->plugin[i] != slot) continue;
    failed = mjfx_read_part(m, d, i, parts + k, keep, err, errsz);
    instance[k++] = i;
  }
  mjfx_measure_end(m, d, saved, 1);
  Table* t = failed ? NULL : mjfx_gather(parts, instance, n, keep);
  if (!failed && !t) snprintf(err, errsz, "mjflex: out of memory");
  for (int j = 0; j < k; j++) mjfx_free_part(parts + j);
  free(parts), free(instance);
  return t;
}

Table* mjfx_read_model(const mjModel* m, mjData* d, int slot, char* err, int errsz) {
  return read_elements(m, d, slot, 0, NULL, NULL, 0, err, errsz);
}

Table* mjfx_read_table(const mjModel* m, mjData* d, int nrec, const char* const* names, const char* const* values,
                       char* err, int errsz) {
  if (!m || !d || nrec < 0 || (nrec && (!names || !values)) || !err || errsz < 1) {
    if (err && errsz > 0) snprintf(err, errsz, "mjflex: mjfx_read_table: invalid arguments");
    return NULL;
  }
  for (long i = 0; i < (long)nrec * MJFX_NATTRIBUTE; i++) {
    if (!values[i] || (i % MJFX_NATTRIBUTE == 0 && !names[i / MJFX_NATTRIBUTE])) {
      snprintf(err, errsz, "mjflex: mjfx_read_table: invalid arguments");
      return NULL;
    }
  }
  return read_elements(m, d, g_slot, nrec, names, values, 1, err, errsz);
}

// Sleeping: whether tree `t` may sleep: its policy lets MuJoCo put it to sleep.
static int may_sleep(const mjModel* m, int t) {
  int policy = m->tree_sleep_policy[t];
  return policy != mjSLEEP_NEVER && policy != mjSLEEP_AUTO_NEVER;
}

// With sleeping enabled, warn (once per mjData) about an element that joins a tree which may sleep to
// another tree or a mocap body: MuJoCo ignores forces on sleeping trees, and only the compiled model's
// policies count (mjflex.add_flexure and python -m mjflex convert write sleep="never" on such trees).
void mjfx_warn_sleepy(const mjModel* m, const Table* t) {
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
      mjfx_instance_name(m, t->instance[first]), count - 1, root[0] ? root : "(unnamed)");
}

