// The registry of per-mjData states (see states.h): two open-addressing hash tables under one lock,
// data address -> entry and state address -> entry.

#include "states.h"

#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include <mujoco/mujoco.h>

#if defined(_WIN32)
#include <windows.h>
#define YIELD() SwitchToThread()
#else
#include <sched.h>
#define YIELD() sched_yield()
#endif

typedef struct Entry_ {
  uintptr_t key;  // EMPTY, TOMB or an address
  const void* buffer;
  void* state;
  void (*free_state)(void*);
} Entry;

typedef struct Map_ {
  Entry* e;
  size_t cap, count, tombs;  // cap: a power of two (0: not allocated yet)
} Map;

#define EMPTY ((uintptr_t)0)
#define TOMB ((uintptr_t)1)

static Map g_by_data, g_by_state;

// The lock: a spin lock that yields (held for a few probes), from C11 atomics only, so that the library
// needs no thread library and ThreadSanitizer sees every acquire and release.
static atomic_flag g_lock = ATOMIC_FLAG_INIT;

static void lock(void) {
  for (int spins = 0; atomic_flag_test_and_set_explicit(&g_lock, memory_order_acquire); spins++) {
    if (spins > 64) YIELD();
  }
}

static void unlock(void) {
  atomic_flag_clear_explicit(&g_lock, memory_order_release);
}

static size_t slot_of(const Map* map, uintptr_t key) {
  uint64_t h = (uint64_t)key * 0x9E3779B97F4A7C15ULL;
  return (size_t)(h ^ (h >> 29)) & (map->cap - 1);
}

// the entry of key, or NULL
static Entry* map_get(Map* map, uintptr_t key) {
  if (!map->cap) return NULL;
  for (size_t i = slot_of(map, key), k = 0; k < map->cap; i = (i + 1) & (map->cap - 1), k++) {
    if (map->e[i].key == key) return map->e + i;
    if (map->e[i].key == EMPTY) return NULL;
  }
  return NULL;
}

static void map_put_fresh(Map* map, const Entry* entry) {
  size_t i = slot_of(map, entry->key);
  while (map->e[i].key > TOMB) i = (i + 1) & (map->cap - 1);
  if (map->e[i].key == TOMB) map->tombs--;
  map->e[i] = *entry;
  map->count++;
}

// room for one more key (rehashing when a quarter would be left free); -1: out of memory
static int map_reserve(Map* map) {
  if (map->cap && 4 * (map->count + map->tombs + 1) <= 3 * map->cap) return 0;
  size_t cap = 64;
  while (cap < 4 * (map->count + 1)) cap *= 2;
  Entry* fresh = calloc(cap, sizeof(Entry));
  if (!fresh) return -1;
  Map next = {fresh, cap, 0, 0};
  for (size_t i = 0; i < map->cap; i++) {
    if (map->e[i].key > TOMB) map_put_fresh(&next, map->e + i);
  }
  free(map->e);
  *map = next;
  return 0;
}

static void map_delete(Map* map, Entry* entry) {
  memset(entry, 0, sizeof(Entry));
  entry->key = TOMB;
  map->count--, map->tombs++;
}

// Unregister the data's entry (lock held); returns it (key EMPTY: there was none).
static Entry take(uintptr_t data) {
  Entry out = {EMPTY, NULL, NULL, NULL};
  Entry* e = map_get(&g_by_data, data);
  if (!e) return out;
  out = *e;
  map_delete(&g_by_data, e);
  Entry* s = map_get(&g_by_state, (uintptr_t)out.state);
  if (s) map_delete(&g_by_state, s);
  return out;
}

static void dispose(const Entry* e) {
  if (e->key != EMPTY && e->free_state) e->free_state(e->state);
}

int mjfx_states_add(const void* data, const void* buffer, void* state, void (*free_state)(void*)) {
  lock();
  Entry old = take((uintptr_t)data);
  int rc = map_reserve(&g_by_data) || map_reserve(&g_by_state) ? -1 : 0;
  if (!rc) {
    Entry e = {(uintptr_t)data, buffer, state, free_state};
    map_put_fresh(&g_by_data, &e);
    e.key = (uintptr_t)state;
    map_put_fresh(&g_by_state, &e);
  }
  unlock();
  dispose(&old);
  return rc;
}

void* mjfx_states_find(const void* data, const void* buffer) {
  lock();
  Entry* e = map_get(&g_by_data, (uintptr_t)data);
  void* state = e ? e->state : NULL;
  Entry stale = {EMPTY, NULL, NULL, NULL};
  if (e && e->buffer != buffer) {
    stale = take((uintptr_t)data);
    state = NULL;
  }
  unlock();
  dispose(&stale);
  return state;
}

void mjfx_states_remove(const void* data) {
  lock();
  Entry old = take((uintptr_t)data);
  unlock();
  dispose(&old);
}

void* mjfx_states_lock_live(uintptr_t word) {
  lock();
  if (word <= TOMB) return NULL;
  Entry* e = map_get(&g_by_state, word);
  return e ? e->state : NULL;
}

void mjfx_states_unlock(void) {
  unlock();
}

long mjfx_states_count(void) {
  lock();
  long n = (long)g_by_data.count;
  unlock();
  return n;
}

//------------------------------------------------------------------------------ snapshots of a model

#define NFIELDS 12
#define NCONFIGURATION 2  // the last fields: the elements' configuration text (the largest part)

// the fields a snapshot holds: their addresses and sizes in m (the configuration last)
static void model_fields(const mjModel* m, const void* at[NFIELDS], size_t bytes[NFIELDS]) {
  int k = 0;
#define FIELD(name, count) (at[k] = m->name, bytes[k++] = sizeof(*m->name) * (size_t)(count))
  FIELD(site_pos, 3 * m->nsite);
  FIELD(site_quat, 4 * m->nsite);
  FIELD(site_bodyid, m->nsite);
  FIELD(body_pos, 3 * m->nbody);
  FIELD(body_quat, 4 * m->nbody);
  FIELD(body_mass, m->nbody);
  FIELD(body_inertia, 3 * m->nbody);
  FIELD(qpos0, m->nq);
  FIELD(jnt_pos, 3 * m->njnt);
  FIELD(jnt_axis, 3 * m->njnt);
  FIELD(plugin_attr, m->npluginattr);
  FIELD(text_data, m->ntextdata);
#undef FIELD
}

size_t mjfx_snapshot_size(const mjModel* m) {
  const void* at[NFIELDS];
  size_t bytes[NFIELDS], total = 0;
  model_fields(m, at, bytes);
  for (int k = 0; k < NFIELDS; k++) total += bytes[k];
  return total;
}

void mjfx_snapshot_take(const mjModel* m, unsigned char* out) {
  const void* at[NFIELDS];
  size_t bytes[NFIELDS];
  model_fields(m, at, bytes);
  for (int k = 0; k < NFIELDS; k++) {
    if (bytes[k]) memcpy(out, at[k], bytes[k]);
    out += bytes[k];
  }
}

int mjfx_snapshot_same(const mjModel* m, const unsigned char* snapshot, int configuration) {
  const void* at[NFIELDS];
  size_t bytes[NFIELDS];
  model_fields(m, at, bytes);
  for (int k = 0; k < (configuration ? NFIELDS : NFIELDS - NCONFIGURATION); k++) {
    if (bytes[k] && memcmp(snapshot, at[k], bytes[k])) return 0;
    snapshot += bytes[k];
  }
  return 1;
}
