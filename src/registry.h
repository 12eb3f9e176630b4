/* registry.h - the registrations between original triangles and level faces
 * (DESIGN.md §3): the bookkeeping the certificate's direction (b) rests on.
 *
 * Original triangle t is certified within eps of the level by the faces it is
 * registered to (at most REGISTRY_SLOTS); each face keeps the list of the
 * originals registered to it, so that when a face changes, exactly the
 * originals whose certificate used it are re-certified. Both sides must agree
 * at all times: that is the invariant registry_verify checks. Flat arrays: a
 * slot is t * REGISTRY_SLOTS + k, and each face's list is an intrusive
 * doubly linked list through the slots. Linking and unlinking are O(1).
 *
 * Clusters. The originals may be grouped into clusters (cluster_of[t]); a
 * cluster can instead be registered whole, to one face that holds every one
 * of its triangles (certify.h, cert_cluster), through one more slot per
 * cluster after the originals' slots. At coarse levels a face holds
 * thousands of originals; re-certifying a few hundred clusters instead is
 * what keeps a collapse there cheap. Each original is covered exactly one
 * way: its cluster is registered whole and it has no slot of its own, or
 * its cluster is not and it has at least one. */
#ifndef LODPIPE_REGISTRY_H
#define LODPIPE_REGISTRY_H

#include <stddef.h>
#include <stdint.h>

#define REGISTRY_SLOTS 4
#define REGISTRY_NONE UINT32_MAX

typedef struct registry {
    uint32_t original_count, face_count, cluster_count;
    const uint32_t *cluster_of; /* borrowed, per original (NULL: no clusters) */
    /* REGISTRY_SLOTS per original, then one per cluster: face, or REGISTRY_NONE */
    uint32_t *slot_face;
    uint32_t *slot_next, *slot_prev;
    uint32_t *face_head; /* first slot of each face's list */
} registry;

/* Every original t registered to face t (the level starts as the original);
 * no cluster registered whole. cluster_of (cluster_count clusters, each
 * value below it) may be NULL with cluster_count 0; it must outlive r. */
int registry_init(registry *r, uint32_t count, const uint32_t *cluster_of, uint32_t cluster_count);
void registry_free(registry *r);

/* Removes every registration of original t. */
void registry_clear(registry *r, uint32_t t);
/* Registers t to `count` faces (after registry_clear). */
void registry_set(registry *r, uint32_t t, const uint32_t *faces, uint32_t count);

/* Registers cluster c whole to face f (after registry_clear_cluster and
 * registry_clear of each of its originals), or removes that registration. */
void registry_set_cluster(registry *r, uint32_t c, uint32_t f);
void registry_clear_cluster(registry *r, uint32_t c);
/* The slot of cluster c: after every original's. */
static inline uint32_t registry_cluster_slot(const registry *r, uint32_t c)
{
    return r->original_count * REGISTRY_SLOTS + c;
}
/* The face cluster c is registered to whole, or REGISTRY_NONE. */
static inline uint32_t registry_cluster_face(const registry *r, uint32_t c)
{
    return r->slot_face[registry_cluster_slot(r, c)];
}
/* For a slot met in a face's list: the cluster it registers, or
 * REGISTRY_NONE when it is an original's (original = slot / REGISTRY_SLOTS). */
static inline uint32_t registry_slot_cluster(const registry *r, uint32_t slot)
{
    const uint32_t base = registry_cluster_slot(r, 0);
    return slot >= base ? slot - base : REGISTRY_NONE;
}

/* Calls visit(context, t) for each original registered to face f (an original
 * registered twice to f is visited twice). */
#define REGISTRY_FOR_EACH(r, f, slot) \
    for (uint32_t slot = (r)->face_head[f]; slot != REGISTRY_NONE; slot = (r)->slot_next[slot])

/* Checks both directions: every slot's face lists the slot, every listed slot
 * names the face, lists are well formed (prev/next agree, no cycles), faces
 * for which face_alive[f] == 0 have empty lists, and every original is
 * covered exactly one way (its own slots or its cluster). Returns 0, or -1
 * with a description in msg. O(originals + clusters + faces). */
int registry_verify(const registry *r, const uint8_t *face_alive, char *msg, size_t msg_size);

#endif
