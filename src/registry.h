/* registry.h - the registrations between original triangles and level faces
 * (DESIGN.md §3): the bookkeeping the certificate's direction (b) rests on.
 *
 * Original triangle t is certified within eps of the level by the faces it is
 * registered to (at most REGISTRY_SLOTS); each face keeps the list of the
 * originals registered to it, so that when a face changes, exactly the
 * originals whose certificate used it are re-certified. Both sides must agree
 * at all times: that is the invariant registry_verify checks. Flat arrays: a
 * slot is t * REGISTRY_SLOTS + k, and each face's list is an intrusive
 * doubly linked list through the slots. Linking and unlinking are O(1). */
#ifndef LODPIPE_REGISTRY_H
#define LODPIPE_REGISTRY_H

#include <stddef.h>
#include <stdint.h>

#define REGISTRY_SLOTS 4
#define REGISTRY_NONE UINT32_MAX

typedef struct registry {
    uint32_t original_count, face_count;
    uint32_t *slot_face; /* REGISTRY_SLOTS per original: face, or REGISTRY_NONE */
    uint32_t *slot_next, *slot_prev;
    uint32_t *face_head; /* first slot of each face's list */
} registry;

/* Every original t registered to face t (the level starts as the original). */
int registry_init(registry *r, uint32_t count);
void registry_free(registry *r);

/* Removes every registration of original t. */
void registry_clear(registry *r, uint32_t t);
/* Registers t to `count` faces (after registry_clear). */
void registry_set(registry *r, uint32_t t, const uint32_t *faces, uint32_t count);

/* Calls visit(context, t) for each original registered to face f (an original
 * registered twice to f is visited twice). */
#define REGISTRY_FOR_EACH(r, f, slot) \
    for (uint32_t slot = (r)->face_head[f]; slot != REGISTRY_NONE; slot = (r)->slot_next[slot])

/* Checks both directions: every slot's face lists the slot, every listed slot
 * names the face, lists are well formed (prev/next agree, no cycles), and
 * faces for which face_alive[f] == 0 have empty lists. Returns 0, or -1 with
 * a description in msg. O(originals + faces). */
int registry_verify(const registry *r, const uint8_t *face_alive, char *msg, size_t msg_size);

#endif
