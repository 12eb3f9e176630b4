/* registry.c - see registry.h. */
#include "registry.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void unlink_slot(registry *r, uint32_t s)
{
    uint32_t f = r->slot_face[s];
    if (f == REGISTRY_NONE) return;
    if (r->slot_prev[s] != REGISTRY_NONE) r->slot_next[r->slot_prev[s]] = r->slot_next[s];
    else r->face_head[f] = r->slot_next[s];
    if (r->slot_next[s] != REGISTRY_NONE) r->slot_prev[r->slot_next[s]] = r->slot_prev[s];
    r->slot_face[s] = r->slot_next[s] = r->slot_prev[s] = REGISTRY_NONE;
}

static void link_slot(registry *r, uint32_t s, uint32_t f)
{
    r->slot_face[s] = f;
    r->slot_prev[s] = REGISTRY_NONE;
    r->slot_next[s] = r->face_head[f];
    if (r->face_head[f] != REGISTRY_NONE) r->slot_prev[r->face_head[f]] = s;
    r->face_head[f] = s;
}

int registry_init(registry *r, uint32_t count, const uint32_t *cluster_of, uint32_t cluster_count)
{
    memset(r, 0, sizeof *r);
    const size_t slots = (size_t)count * REGISTRY_SLOTS + cluster_count;
    r->original_count = r->face_count = count;
    r->cluster_count = cluster_count;
    r->cluster_of = cluster_of;
    r->slot_face = malloc((slots + 1) * sizeof *r->slot_face);
    r->slot_next = malloc((slots + 1) * sizeof *r->slot_next);
    r->slot_prev = malloc((slots + 1) * sizeof *r->slot_prev);
    r->face_head = malloc(((size_t)count + 1) * sizeof *r->face_head);
    if (!r->slot_face || !r->slot_next || !r->slot_prev || !r->face_head) {
        registry_free(r);
        return -1;
    }
    memset(r->slot_face, 0xff, (slots + 1) * sizeof *r->slot_face);
    memset(r->slot_next, 0xff, (slots + 1) * sizeof *r->slot_next);
    memset(r->slot_prev, 0xff, (slots + 1) * sizeof *r->slot_prev);
    memset(r->face_head, 0xff, ((size_t)count + 1) * sizeof *r->face_head);
    for (uint32_t t = 0; t < count; ++t) link_slot(r, t * REGISTRY_SLOTS, t);
    return 0;
}

void registry_free(registry *r)
{
    free(r->slot_face);
    free(r->slot_next);
    free(r->slot_prev);
    free(r->face_head);
    memset(r, 0, sizeof *r);
}

void registry_clear(registry *r, uint32_t t)
{
    for (uint32_t k = 0; k < REGISTRY_SLOTS; ++k) unlink_slot(r, t * REGISTRY_SLOTS + k);
}

void registry_set(registry *r, uint32_t t, const uint32_t *faces, uint32_t count)
{
    for (uint32_t k = 0; k < count && k < REGISTRY_SLOTS; ++k) link_slot(r, t * REGISTRY_SLOTS + k, faces[k]);
}

void registry_set_cluster(registry *r, uint32_t c, uint32_t f)
{
    link_slot(r, registry_cluster_slot(r, c), f);
}

void registry_clear_cluster(registry *r, uint32_t c)
{
    unlink_slot(r, registry_cluster_slot(r, c));
}

int registry_verify(const registry *r, const uint8_t *face_alive, char *msg, size_t msg_size)
{
    const size_t slots = (size_t)r->original_count * REGISTRY_SLOTS + r->cluster_count;
    size_t listed = 0;
    for (uint32_t f = 0; f < r->face_count; ++f) {
        uint32_t prev = REGISTRY_NONE;
        size_t steps = 0;
        for (uint32_t s = r->face_head[f]; s != REGISTRY_NONE; s = r->slot_next[s]) {
            if (s >= slots) {
                snprintf(msg, msg_size, "face %u lists slot %u, which does not exist", f, s);
                return -1;
            }
            if (r->slot_face[s] != f) {
                snprintf(msg, msg_size, "face %u lists slot %u, which is registered to face %d", f, s,
                         (int)r->slot_face[s]);
                return -1;
            }
            if (r->slot_prev[s] != prev) {
                snprintf(msg, msg_size, "face %u: broken back link at slot %u", f, s);
                return -1;
            }
            if (face_alive && !face_alive[f]) {
                snprintf(msg, msg_size, "dead face %u still has slot %u registered", f, s);
                return -1;
            }
            if (++steps > slots) {
                snprintf(msg, msg_size, "face %u: list does not end", f);
                return -1;
            }
            prev = s;
        }
        listed += steps;
    }
    size_t registered = 0;
    for (size_t s = 0; s < slots; ++s) {
        if (r->slot_face[s] == REGISTRY_NONE) continue;
        if (r->slot_face[s] >= r->face_count) {
            snprintf(msg, msg_size, "slot %zu is registered to face %u, which does not exist", s, r->slot_face[s]);
            return -1;
        }
        registered++;
    }
    if (registered != listed) {
        snprintf(msg, msg_size, "%zu registrations but the faces list %zu", registered, listed);
        return -1;
    }
    for (uint32_t t = 0; t < r->original_count; ++t) {
        int any = 0;
        for (uint32_t k = 0; k < REGISTRY_SLOTS; ++k) any |= r->slot_face[t * REGISTRY_SLOTS + k] != REGISTRY_NONE;
        const int whole = r->cluster_of && registry_cluster_face(r, r->cluster_of[t]) != REGISTRY_NONE;
        if (!any && !whole) {
            snprintf(msg, msg_size, "original %u is registered to no face", t);
            return -1;
        }
        if (any && whole) {
            snprintf(msg, msg_size, "original %u is registered both itself and through its cluster %u", t,
                     r->cluster_of[t]);
            return -1;
        }
    }
    return 0;
}
