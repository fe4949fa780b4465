// The registry of per-mjData states of the engine plugin (plugin.c explains why it exists): a
// process-wide map from an mjData's address to the one allocation that holds all of that data's
// mjflex state, and the set of those allocations' own addresses.
//
// Rules:
// * Every function is thread-safe (one lock, held for a few probes of an open-addressing table;
//   growing the table, rare, holds it longer).
// * A state belongs to one data. Only calls for that data free it (add replacing it, remove, a
//   find that meets it stale), so a state that find returned stays valid while the caller works on
//   its data: MuJoCo's contract is that one data is used by one thread at a time.
// * An entry records the data's buffer address when it was made (the generation). find for a data
//   whose buffer differs frees the entry, left by a data freed without MuJoCo calling destroy, and
//   returns NULL: a state is never taken for another data that lives at the same address.
// * A word from d->plugin_data is a key for lock_live only: it is never dereferenced unless it is
//   the address of a live state, and the lock is held while the caller reads that state.

#ifndef MJFLEX_NATIVE_STATES_H_
#define MJFLEX_NATIVE_STATES_H_

#include <stddef.h>
#include <stdint.h>

#include <mujoco/mjmodel.h>

// Register `state` as the state of `data` (buffer: data->buffer), freeing with free_state any state
// registered for data before. 0, or -1 when out of memory (nothing registered then).
int mjfx_states_add(const void* data, const void* buffer, void* state, void (*free_state)(void*));

// The state of data, or NULL (none, or a stale one, which is freed).
void* mjfx_states_find(const void* data, const void* buffer);

// Forget and free the state of data, if any.
void mjfx_states_remove(const void* data);

// Take the lock and return the state whose address is `word`, or NULL (the lock is taken either
// way): the caller reads or writes the state, then calls mjfx_states_unlock.
void* mjfx_states_lock_live(uintptr_t word);
void mjfx_states_unlock(void);

// Number of registered states (for tests).
long mjfx_states_count(void);

// What an element table was read from. The registry knows a model by address, signature and sizes; an
// in-place edit (Python's model.site_pos[...] = ..., model.qpos0[...] = ...) changes none of them, and a
// table read before it (rest offsets measured at qpos0, levers, masses) would be stale. A snapshot is a
// copy of the bytes of every model field the element reader uses (mjfx_read_element: the sites' and
// bodies' poses, qpos0, the joints' positions and axes, masses and inertias, the plugin configuration,
// the text records); comparing it is a few memcmp calls (no hashing), done where it is cheap: once per
// step (plugin.c: at a step's first evaluation; callback.c: once per step's worth of time), the
// configuration text only where a run starts (a new data, a reset).
// bytes of m's snapshot
size_t mjfx_snapshot_size(const mjModel* m);

// write m's snapshot (mjfx_snapshot_size(m) bytes) into out
void mjfx_snapshot_take(const mjModel* m, unsigned char* out);

// 1 if m's fields are the snapshot's bytes (taken from m, or a model of m's sizes), else 0. Without
// `configuration`, the configuration text (plugin_attr, text_data: in ARCADE 23 of its 38 kB) is not compared:
// the poses, qpos0, joints and masses are, each step; the text where a run starts.
int mjfx_snapshot_same(const mjModel* m, const unsigned char* snapshot, int configuration);

#endif  // MJFLEX_NATIVE_STATES_H_
