// The mjcb_passive provider for text-record models: one process-global dispatcher and a
// registry of the models it serves (mjflex/runtime/registry.py fills it).
//
// Rules (the registry semantics mjflex's tests guard):
// * A slot is in use when its model pointer is non-NULL. Python fills a slot's fields before it
//   stores the model pointer (release) and clears the pointer first when it frees the slot, so
//   a dispatcher running in another thread for another model never reads a half-written slot.
//   Slots never move; only the first g_used can be in use. The tables a slot points to are
//   owned by Python and outlive the slot.
// * The dispatcher allocates nothing and validates nothing: the tables were validated when the
//   provider was built.
// * Models not in the registry (other models, the temporary ones MuJoCo builds while
//   compiling) are left untouched; a previous C callback is called first (chained).
// * The tables are checked once, when a slot is published (mjfx_check_rows): a table that could
//   index past the model's arrays is refused.
// * Divergence: each slot has MJFX_WATCHES per-mjData watch entries, claimed by data address;
//   when all are taken the least recently used is reclaimed, so a diagnostic may be approximate
//   when more mjData of one model are alive at once than there are entries. An entry is used
//   (read, cleared or written) only by the thread that holds its busy flag (an atomic
//   compare-exchange): two threads that reclaim the same entry at once cannot both use it (the
//   loser evaluates without diagnostics), and an entry is never cleared while another thread
//   uses it (tests/test_native_sanitizers.py runs this under ThreadSanitizer).

#include <stdatomic.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <mujoco/mujoco.h>

#include "api.h"
#include "elements.h"
#include "states.h"

#define MJFX_CAPACITY 1024
#define MJFX_WATCHES 64

// A watch entry: this header, then the watch with its tallies at WATCH_AT (ISO C allows no member
// of a type with a flexible array, so the watch follows the header instead of being its last field)
typedef struct Record_ {
  _Atomic uintptr_t owner;  // the mjData address, 0 when free
  _Atomic uint64_t stamp;   // last use (for reclaiming)
  _Atomic int busy;         // 1 while a thread uses the entry
  int compared;             // the model was compared with the slot's snapshot (at time `at`) for this data
  double at;
} Entry;

#define WATCH_AT ((sizeof(Entry) + _Alignof(mjfxWatch) - 1) / _Alignof(mjfxWatch) * _Alignof(mjfxWatch))

static mjfxWatch* watch_of(Entry* entry) {
  return (mjfxWatch*)((unsigned char*)entry + WATCH_AT);
}

typedef struct Slot_ {
  _Atomic(const mjModel*) model;
  int n;
  const mjfxElement* el;
  const int* chain;
  const int* exps;
  const double* coefs;
  const char* const* names;
  unsigned char* entries;          // MJFX_WATCHES entries of entry_size(n) bytes
  const unsigned char* snapshot;   // the model's fields when published (states.h: an in-place edit since)
  _Atomic int edited;              // the edit was said
} Slot;

static Slot g_slots[MJFX_CAPACITY];
static _Atomic int g_used = 0;
static _Atomic uint64_t g_clock = 0;
static void (*_Atomic g_previous)(const mjModel*, mjData*) = NULL;

static size_t entry_size(int n) {
  size_t size = WATCH_AT + mjfx_watch_size(n);
  return (size + 15) & ~(size_t)15;
}

int mjfx_registry_capacity(void) {
  return MJFX_CAPACITY;
}

size_t mjfx_registry_watches_size(int n) {
  return MJFX_WATCHES * entry_size(n);
}

// Prepare a buffer of mjfx_registry_watches_size(n) bytes: every watch entry free.
void mjfx_registry_watches_init(unsigned char* entries, int n) {
  for (int r = 0; r < MJFX_WATCHES; r++) {
    Entry* entry = (Entry*)(entries + r * entry_size(n));
    atomic_store(&entry->owner, 0);
    atomic_store(&entry->stamp, 0);
    atomic_store(&entry->busy, 0);
    entry->compared = 0;
    watch_of(entry)->exact = 0;
    mjfx_watch_clear(watch_of(entry), n);
  }
}

// Serve model m from slot `slot` with a table of n elements (chain: nchain dof ids, nterms rows of terms);
// snapshot: mjfx_snapshot_size(m) bytes, written here, compared at every evaluation (an in-place edit of m
// since makes the table stale: NaN forces, said once). 0, or -1 when the slot is out of range or the table is
// not sound (nothing published).
int mjfx_registry_publish(int slot, const mjModel* m, int n, const mjfxElement* el, const int* chain, int nchain,
                          const int* exps, const double* coefs, int nterms, const char* const* names,
                          unsigned char* entries, unsigned char* snapshot) {
  if (slot < 0 || slot >= MJFX_CAPACITY || !entries || !snapshot ||
      mjfx_check_rows(m, el, n, chain, nchain, exps, coefs, nterms) >= 0) {
    return -1;
  }
  Slot* s = g_slots + slot;
  s->n = n, s->el = el, s->chain = chain, s->exps = exps, s->coefs = coefs, s->names = names;
  s->entries = entries;
  mjfx_snapshot_take(m, snapshot);
  s->snapshot = snapshot;
  atomic_store(&s->edited, 0);
  atomic_store_explicit(&s->model, m, memory_order_release);  // last: the slot becomes visible complete
  int used = atomic_load(&g_used);
  while (used < slot + 1 && !atomic_compare_exchange_weak(&g_used, &used, slot + 1)) {
  }
  return 0;
}

void mjfx_registry_clear(int slot) {
  if (slot < 0 || slot >= MJFX_CAPACITY) return;
  atomic_store_explicit(&g_slots[slot].model, NULL, memory_order_release);  // first: no dispatcher matches it
  int used = atomic_load(&g_used);
  while (used > 0 && atomic_load(&g_slots[used - 1].model) == NULL) used--;
  atomic_store(&g_used, used);
}

int mjfx_registry_used(void) {
  return atomic_load(&g_used);
}

void mjfx_set_previous(void (*previous)(const mjModel*, mjData*)) {
  atomic_store(&g_previous, previous);
}

static Slot* slot_of(const mjModel* m) {
  int used = atomic_load(&g_used);
  for (int s = 0; s < used; s++) {
    if (atomic_load_explicit(&g_slots[s].model, memory_order_acquire) == m) return g_slots + s;
  }
  return NULL;
}

static uintptr_t mix(uintptr_t x) {
  x ^= x >> 17;
  x *= (uintptr_t)0xed5ad4bbU;
  x ^= x >> 11;
  return x;
}

// take an entry's busy flag (0: another thread uses it)
static int take(Entry* entry) {
  int expected = 0;
  return atomic_compare_exchange_strong_explicit(&entry->busy, &expected, 1, memory_order_acquire, memory_order_relaxed);
}

static void give(Entry* entry) {
  atomic_store_explicit(&entry->busy, 0, memory_order_release);
}

// The entry of d in entries (of n elements), its busy flag taken: found, claimed if free, or
// reclaimed from the least recently used; NULL when none can be had (the caller goes on without
// diagnostics). The caller gives the flag back (give) when done with the watch.
static Entry* entry_in(unsigned char* entries, int n, const mjData* d, int claim) {
  size_t size = entry_size(n);
  uintptr_t key = (uintptr_t)d;
  int start = (int)(mix(key) % MJFX_WATCHES);
  uint64_t now = atomic_fetch_add_explicit(&g_clock, 1, memory_order_relaxed) + 1;
  for (int k = 0; k < MJFX_WATCHES; k++) {
    Entry* entry = (Entry*)(entries + ((start + k) % MJFX_WATCHES) * size);
    if (atomic_load_explicit(&entry->owner, memory_order_acquire) != key) continue;
    if (!take(entry)) return NULL;  // d is being evaluated in another thread, or its entry reclaimed right now
    if (atomic_load_explicit(&entry->owner, memory_order_relaxed) == key) {
      atomic_store_explicit(&entry->stamp, now, memory_order_relaxed);
      return entry;
    }
    give(entry);  // reclaimed for another data meanwhile
    break;
  }
  if (!claim) return NULL;
  for (int attempt = 0; attempt < 4; attempt++) {
    Entry* oldest = NULL;
    uint64_t oldest_stamp = UINT64_MAX;
    for (int k = 0; k < MJFX_WATCHES; k++) {
      Entry* entry = (Entry*)(entries + ((start + k) % MJFX_WATCHES) * size);
      if (atomic_load_explicit(&entry->busy, memory_order_relaxed)) continue;
      uintptr_t owner = atomic_load(&entry->owner);
      uint64_t stamp = owner ? atomic_load_explicit(&entry->stamp, memory_order_relaxed) : 0;
      if (stamp < oldest_stamp) oldest = entry, oldest_stamp = stamp;
      if (!owner) break;
    }
    if (oldest && take(oldest)) {
      atomic_store_explicit(&oldest->owner, key, memory_order_release);
      mjfx_watch_clear(watch_of(oldest), n);
      oldest->compared = 0;
      atomic_store_explicit(&oldest->stamp, now, memory_order_relaxed);
      return oldest;
    }
  }
  return NULL;  // lost every race: no diagnostics for this evaluation
}

static const char* element_name(const Slot* s, int e) {
  return e >= 0 && e < s->n && s->names && s->names[e] ? s->names[e] : "?";
}

// Whether m is as the slot's snapshot: compared about once per step (the data's first evaluation; then one
// at least a step of d's time after the last that matched, one at that same time again, as mj_forward after a
// step, or one after time ran back), the configuration text where d's run starts; without an entry (lost to
// another thread), at every evaluation. RK4 compares twice per step (its last stage, the next step's first).
static int unedited(const mjModel* m, const Slot* s, const mjData* d, Entry* entry) {
  int again = entry && entry->compared && d->time >= entry->at;
  if (again && d->time > entry->at && d->time < entry->at + (1.0 - 1e-9) * m->opt.timestep) return 1;
  if (!mjfx_snapshot_same(m, s->snapshot, !again)) return 0;
  if (entry) entry->compared = 1, entry->at = d->time;
  return 1;
}

// Evaluate the served elements of m on d; returns 0 if m is not served. With report, verdicts
// are reported through MuJoCo here; else they are written to out[0..2) for the caller. The entry
// is given back before anything is reported: a report may raise (mju_error), leaving this function.
int mjfx_dispatch(const mjModel* m, mjData* d, int report, mjfxVerdict out[2]) {
  Slot* s = slot_of(m);
  if (out) out[0].element = out[1].element = -1;
  if (!s) return 0;
  Entry* entry = entry_in(s->entries, s->n, d, 1);
  if (!unedited(m, s, d, entry)) {  // edited in place since the provider was built: stale table
    if (entry) give(entry);
    for (int i = 0; i < m->nv; i++) d->qfrc_passive[i] = NAN;
    if (!atomic_exchange(&s->edited, 1)) {
      mju_warning("mjflex: model '%.100s' was edited in place after its mjflex.Flexures was built (a field its "
                  "elements are read from: a site's or body's pose, qpos0, a joint, a mass, a text record): its "
                  "text-record elements' forces are NaN. An element is unstressed at the pose its sites had when the "
                  "Flexures was built: build a new mjflex.Flexures(model) after editing",
                  m->names[0] ? m->names : "unnamed");
    }
    return 1;
  }
  mjfxVerdict v[2] = {{.element = -1}, {.element = -1}};
  if (entry) mjfx_watch_judge(watch_of(entry), m, d, 1, v);
  mjfxScan scan;
  int bad = mjfx_evaluate(m, d, s->el, s->n, s->chain, s->exps, s->coefs, MJFX_APPLY, d->qfrc_passive, NULL, NULL,
                          &scan);
  if (bad >= 0) {
    for (int i = 0; i < m->nv; i++) d->qfrc_passive[i] = NAN;  // so that MuJoCo's checks see it too
  }
  if (entry) {
    mjfx_watch_record(watch_of(entry), m, d, &scan, 1, v + 1);
    give(entry);
  }
  for (int k = 0; k < 2; k++) {
    if (report) mjfx_report(m, v + k, element_name(s, v[k].element));
    else if (out) out[k] = v[k];
  }
  return 1;
}

// The process's passive callback.
void mjfx_passive(const mjModel* m, mjData* d) {
  void (*previous)(const mjModel*, mjData*) = atomic_load(&g_previous);
  if (previous) previous(m, d);
  mjfx_dispatch(m, d, 1, NULL);
}

// The watch of d in a entries buffer of n elements (NULL if none), for Python's queries between steps.
const mjfxWatch* mjfx_registry_watch(unsigned char* entries, int n, const mjData* d) {
  Entry* entry = entries ? entry_in(entries, n, d, 0) : NULL;
  if (entry) give(entry);
  return entry ? watch_of(entry) : NULL;
}
