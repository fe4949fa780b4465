// The registry of per-mjData states (see states.h): two open-addressing hash tables under one lock,
// data address -> entry and state address -> entry.

#include "states.h"

#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

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
