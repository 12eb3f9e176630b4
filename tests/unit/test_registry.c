/* test_registry.c - the registrations between original triangles and level
 * faces (registry.h, DESIGN.md §3): set / clear against a brute-force model of
 * both directions, then the invariant checker registry_verify on an intact
 * registry (0) and on a dozen different corruptions of slot_face, slot_next,
 * slot_prev and face_head, each of which must be caught (-1, with a message). */
#include "check.h"
#include "registry.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static uint64_t rng_state = 0x7265676973747279ULL;

static uint32_t rng_below(uint32_t n)
{
    uint64_t z = (rng_state += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return (uint32_t)((z ^ (z >> 31)) % n);
}

/* How many times face f lists original t (walking f's list). */
static uint32_t listed(const registry *r, uint32_t f, uint32_t t)
{
    uint32_t n = 0, steps = 0;
    REGISTRY_FOR_EACH(r, f, slot) {
        if (slot / REGISTRY_SLOTS == t) n++;
        if (++steps > r->original_count * REGISTRY_SLOTS) break;
    }
    return n;
}

/* Both directions against the model: model[t * SLOTS + k] = face or NONE. */
static int agrees(const registry *r, const uint32_t *model)
{
    for (uint32_t t = 0; t < r->original_count; ++t)
        for (uint32_t f = 0; f < r->face_count; ++f) {
            uint32_t want = 0;
            for (uint32_t k = 0; k < REGISTRY_SLOTS; ++k) want += model[t * REGISTRY_SLOTS + k] == f;
            if (listed(r, f, t) != want) return 0;
        }
    for (uint32_t s = 0; s < r->original_count * REGISTRY_SLOTS; ++s) {
        uint32_t t = s / REGISTRY_SLOTS, f = r->slot_face[s];
        if (f == REGISTRY_NONE) continue;
        uint32_t want = 0;
        for (uint32_t k = 0; k < REGISTRY_SLOTS; ++k) want += model[t * REGISTRY_SLOTS + k] == f;
        if (!want) return 0;
    }
    return 1;
}

static int verify(const registry *r, const uint8_t *alive, char *msg)
{
    msg[0] = 0;
    return registry_verify(r, alive, msg, 200);
}

static void test_init_set_clear(void)
{
    registry r;
    const uint32_t n = 40;
    CHECK(registry_init(&r, n, NULL, 0) == 0, "registry_init");
    uint32_t *model = malloc(n * REGISTRY_SLOTS * sizeof *model);
    uint8_t *alive = malloc(n);
    memset(model, 0xff, n * REGISTRY_SLOTS * sizeof *model);
    memset(alive, 1, n);
    for (uint32_t t = 0; t < n; ++t) model[t * REGISTRY_SLOTS] = t;
    char msg[256];
    CHECK(agrees(&r, model), "after init every original is registered to its own face");
    CHECK(verify(&r, alive, msg) == 0, "intact after init: %s", msg);
    /* random re-registrations, as commits do: clear then set 1..4 faces
     * (distinct or not), checking both directions each time */
    int ok = 1;
    for (int step = 0; step < 2000; ++step) {
        uint32_t t = rng_below(n), count = 1 + rng_below(REGISTRY_SLOTS), faces[REGISTRY_SLOTS];
        for (uint32_t k = 0; k < count; ++k) faces[k] = rng_below(n);
        registry_clear(&r, t);
        registry_set(&r, t, faces, count);
        for (uint32_t k = 0; k < REGISTRY_SLOTS; ++k) model[t * REGISTRY_SLOTS + k] = k < count ? faces[k] : REGISTRY_NONE;
        if (step % 97 == 0 && !agrees(&r, model)) ok = 0;
        if (verify(&r, NULL, msg) != 0) {
            ok = 0;
            CHECK(0, "step %d: intact registry reported broken: %s", step, msg);
            break;
        }
    }
    CHECK(ok && agrees(&r, model), "registrations agree with the model both ways");
    /* faces that nobody uses any more may die */
    memset(alive, 0, n);
    for (uint32_t s = 0; s < n * REGISTRY_SLOTS; ++s)
        if (model[s] != REGISTRY_NONE) alive[model[s]] = 1;
    CHECK(verify(&r, alive, msg) == 0, "intact with unused faces dead: %s", msg);
    free(model);
    free(alive);
    registry_free(&r);
    CHECK(r.slot_face == NULL && r.face_head == NULL, "registry_free zeroes");
}

/* A small registry with lists of length > 1 to corrupt: 8 originals, 8
 * faces; originals 0..3 registered to faces {0, 1}, 4..5 to {1, 2, 3},
 * 6 to {7}, 7 to {7, 1}. Faces 4, 5, 6 are unused. */
static void build_small(registry *r)
{
    if (registry_init(r, 8, NULL, 0) != 0) abort();
    static const uint32_t sets[8][3] = {{0, 1}, {0, 1}, {0, 1}, {0, 1}, {1, 2, 3}, {1, 2, 3}, {7}, {7, 1}};
    static const uint32_t counts[8] = {2, 2, 2, 2, 3, 3, 1, 2};
    for (uint32_t t = 0; t < 8; ++t) {
        registry_clear(r, t);
        registry_set(r, t, sets[t], counts[t]);
    }
}

/* The slot of original t that holds face f. */
static uint32_t slot_of(const registry *r, uint32_t t, uint32_t f)
{
    for (uint32_t k = 0; k < REGISTRY_SLOTS; ++k)
        if (r->slot_face[t * REGISTRY_SLOTS + k] == f) return t * REGISTRY_SLOTS + k;
    abort();
}

/* Last slot of face f's list. */
static uint32_t tail_of(const registry *r, uint32_t f)
{
    uint32_t s = r->face_head[f];
    while (r->slot_next[s] != REGISTRY_NONE) s = r->slot_next[s];
    return s;
}

enum {
    C_SLOT_FACE_OTHER,    /* a listed slot names another (existing) face */
    C_SLOT_FACE_NONE,     /* a listed slot names no face */
    C_SLOT_FACE_RANGE,    /* a slot names a face that does not exist */
    C_UNLISTED,           /* a registration no face lists (dropped from the list) */
    C_NEXT_SKIP,          /* slot_next skips one element (prev links kept) */
    C_NEXT_CYCLE,         /* slot_next loops back to the head */
    C_NEXT_SELF,          /* slot_next points at itself */
    C_NEXT_RANGE,         /* slot_next beyond the slot array */
    C_NEXT_OTHER_LIST,    /* a list's tail continues into another face's list */
    C_PREV_WRONG,         /* a back link names the wrong slot */
    C_HEAD_NONE,          /* a face forgets its whole list */
    C_HEAD_SWAP,          /* two faces swap their lists */
    C_HEAD_RANGE,         /* head beyond the slot array */
    C_HEAD_MIDDLE,        /* head points into the middle of its own list */
    C_DEAD_FACE,          /* a dead face still lists originals */
    C_ORPHAN,             /* an original registered to no face */
    C_DUP_SLOT_FACE,      /* the same slot also linked into another face's list */
    C_COUNT
};

static const char *corruption_name[C_COUNT] = {
    "slot_face names another face", "slot_face NONE while listed", "slot_face out of range",
    "registration not listed",      "slot_next skips one",         "slot_next cycles to head",
    "slot_next to itself",          "slot_next out of range",      "list continues into another list",
    "slot_prev wrong",              "face_head NONE",              "face_head swapped",
    "face_head out of range",       "face_head mid-list",          "dead face with originals",
    "original registered nowhere",  "slot in two lists"};

/* Applies corruption c; *alive_out gets a face_alive array (or NULL). */
static void corrupt(registry *r, int c, uint8_t *alive, const uint8_t **alive_out)
{
    const uint32_t slots = r->original_count * REGISTRY_SLOTS;
    *alive_out = NULL;
    switch (c) {
    case C_SLOT_FACE_OTHER: r->slot_face[slot_of(r, 1, 0)] = 2; break;
    case C_SLOT_FACE_NONE: r->slot_face[slot_of(r, 2, 1)] = REGISTRY_NONE; break;
    case C_SLOT_FACE_RANGE: {
        /* unlink original 6's only slot properly, then point it past the faces */
        uint32_t s = slot_of(r, 6, 7);
        registry_clear(r, 6);
        r->slot_face[s] = 9;
        break;
    }
    case C_UNLISTED: {
        /* take original 3's slot out of face 0's list, links mended, slot_face kept */
        uint32_t s = slot_of(r, 3, 0), p = r->slot_prev[s], n = r->slot_next[s];
        if (p != REGISTRY_NONE) r->slot_next[p] = n;
        else r->face_head[0] = n;
        if (n != REGISTRY_NONE) r->slot_prev[n] = p;
        r->slot_next[s] = r->slot_prev[s] = REGISTRY_NONE;
        break;
    }
    case C_NEXT_SKIP: {
        uint32_t h = r->face_head[1];
        r->slot_next[h] = r->slot_next[r->slot_next[h]];
        break;
    }
    case C_NEXT_CYCLE: r->slot_next[tail_of(r, 0)] = r->face_head[0]; break;
    case C_NEXT_SELF: {
        uint32_t h = r->face_head[1];
        r->slot_next[r->slot_next[h]] = r->slot_next[h];
        break;
    }
    case C_NEXT_RANGE: r->slot_next[tail_of(r, 2)] = slots + 3; break;
    case C_NEXT_OTHER_LIST: {
        uint32_t t2 = tail_of(r, 2), h3 = r->face_head[3];
        r->slot_next[t2] = h3;
        r->slot_prev[h3] = t2; /* even with the back link made consistent */
        break;
    }
    case C_PREV_WRONG: {
        uint32_t h = r->face_head[0], second = r->slot_next[h];
        r->slot_prev[r->slot_next[second]] = h;
        break;
    }
    case C_HEAD_NONE: r->face_head[3] = REGISTRY_NONE; break;
    case C_HEAD_SWAP: {
        uint32_t x = r->face_head[0];
        r->face_head[0] = r->face_head[2];
        r->face_head[2] = x;
        break;
    }
    case C_HEAD_RANGE: r->face_head[5] = slots + 1; break;
    case C_HEAD_MIDDLE: r->face_head[0] = r->slot_next[r->face_head[0]]; break;
    case C_DEAD_FACE:
        memset(alive, 1, r->face_count);
        alive[3] = 0;
        *alive_out = alive;
        break;
    case C_ORPHAN: registry_clear(r, 5); break;
    case C_DUP_SLOT_FACE: {
        /* original 6's slot (face 7) also pushed onto face 4's empty list */
        uint32_t s = slot_of(r, 6, 7);
        r->face_head[4] = s;
        break;
    }
    default: abort();
    }
}

static void test_verify_catches_corruption(void)
{
    registry r;
    char msg[256];
    uint8_t alive[8];
    build_small(&r);
    CHECK(verify(&r, NULL, msg) == 0, "intact: %s", msg);
    memset(alive, 1, sizeof alive);
    alive[4] = alive[5] = alive[6] = 0; /* unused faces may be dead */
    CHECK(verify(&r, alive, msg) == 0, "intact with unused faces dead: %s", msg);
    registry_free(&r);
    for (int c = 0; c < C_COUNT; ++c) {
        build_small(&r);
        const uint8_t *a;
        corrupt(&r, c, alive, &a);
        int rc = verify(&r, a, msg);
        CHECK(rc == -1, "corruption \"%s\" not caught (rc %d)", corruption_name[c], rc);
        CHECK(rc == 0 || msg[0] != 0, "corruption \"%s\": no message", corruption_name[c]);
        registry_free(&r);
    }
}

/* Random single-word corruptions of a larger registry: whatever word changes,
 * the checker must either report it or the registry must still agree with the
 * model both ways (a change that happens to be harmless, e.g. an unused
 * head's NONE written again). */
static void test_verify_random_corruption(void)
{
    const uint32_t n = 30;
    int caught = 0, harmless = 0, missed = 0;
    for (int trial = 0; trial < 600; ++trial) {
        registry r;
        if (registry_init(&r, n, NULL, 0) != 0) abort();
        uint32_t model[30 * REGISTRY_SLOTS];
        memset(model, 0xff, sizeof model);
        for (uint32_t t = 0; t < n; ++t) {
            uint32_t count = 1 + rng_below(3), faces[3];
            for (uint32_t k = 0; k < count; ++k) faces[k] = rng_below(n / 3); /* long lists */
            registry_clear(&r, t);
            registry_set(&r, t, faces, count);
            for (uint32_t k = 0; k < count; ++k) model[t * REGISTRY_SLOTS + k] = faces[k];
        }
        char msg[256];
        if (verify(&r, NULL, msg) != 0) {
            CHECK(0, "trial %d: intact registry reported broken: %s", trial, msg);
            registry_free(&r);
            continue;
        }
        const uint32_t slots = n * REGISTRY_SLOTS;
        uint32_t which = rng_below(4), idx, value;
        uint32_t *arr;
        switch (which) {
        case 0: arr = r.slot_face; idx = rng_below(slots); break;
        case 1: arr = r.slot_next; idx = rng_below(slots); break;
        case 2: arr = r.slot_prev; idx = rng_below(slots); break;
        default: arr = r.face_head; idx = rng_below(n); break;
        }
        uint32_t kind = rng_below(3);
        value = kind == 0 ? REGISTRY_NONE : (kind == 1 ? rng_below(which == 0 || which == 3 ? n : slots) : rng_below(slots + 8));
        if (arr[idx] == value) {
            registry_free(&r);
            continue;
        }
        arr[idx] = value;
        int rc = verify(&r, NULL, msg);
        if (rc == -1) caught++;
        else {
            /* not reported: then the structure must still be exactly right,
             * and every list must be walkable */
            int fine = agrees(&r, model);
            for (uint32_t s = 0; s < slots && fine; ++s)
                if (r.slot_face[s] != REGISTRY_NONE && r.slot_face[s] >= n) fine = 0;
            if (fine) harmless++;
            else {
                missed++;
                CHECK(0, "trial %d: array %u [%u] := %u broke the registry unnoticed", trial, which, idx, value);
            }
        }
        registry_free(&r);
    }
    printf("#   random corruptions: %d caught, %d harmless (an unused word), %d missed\n", caught, harmless, missed);
    CHECK(caught > 300, "caught %d (harmless %d, missed %d)", caught, harmless, missed);
}

/* Clusters registered whole: 12 originals in 3 clusters of 4. Registering a
 * cluster whole (after clearing its originals) and splitting it again keep
 * the registry intact; an original covered both ways, or neither, is
 * reported. */
static void test_clusters(void)
{
    static const uint32_t cluster_of[12] = {0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2};
    registry r;
    CHECK(registry_init(&r, 12, cluster_of, 3) == 0, "registry_init");
    char msg[256];
    for (uint32_t t = 4; t < 8; ++t) registry_clear(&r, t);
    registry_set_cluster(&r, 1, 9);
    CHECK(registry_cluster_face(&r, 1) == 9 && registry_cluster_face(&r, 0) == REGISTRY_NONE, "cluster 1 whole to face 9");
    CHECK(verify(&r, NULL, msg) == 0, "intact with a whole cluster: %s", msg);
    uint32_t seen = 0, clusters = 0;
    REGISTRY_FOR_EACH(&r, 9, slot) {
        seen++;
        clusters += registry_slot_cluster(&r, slot) == 1;
    }
    CHECK(seen == 2 && clusters == 1, "face 9 lists original 9 and cluster 1: %u slots, %u clusters", seen, clusters);
    uint8_t alive[12];
    memset(alive, 1, sizeof alive);
    alive[9] = 0;
    CHECK(verify(&r, alive, msg) != 0, "a dead face holding a cluster is reported");
    /* covered twice: original 5 registered again while its cluster is whole */
    uint32_t f = 3;
    registry_set(&r, 5, &f, 1);
    CHECK(verify(&r, NULL, msg) != 0 && strstr(msg, "original 5"), "covered twice is reported: %s", msg);
    registry_clear(&r, 5);
    CHECK(verify(&r, NULL, msg) == 0, "intact again: %s", msg);
    /* covered by nothing: the cluster split without its originals registered */
    registry_clear_cluster(&r, 1);
    CHECK(verify(&r, NULL, msg) != 0 && strstr(msg, "registered to no face"), "uncovered is reported: %s", msg);
    for (uint32_t t = 4; t < 8; ++t) registry_set(&r, t, &f, 1);
    CHECK(verify(&r, NULL, msg) == 0, "split and registered one by one: %s", msg);
    registry_free(&r);
}

int main(void)
{
    RUN(test_init_set_clear);
    RUN(test_verify_catches_corruption);
    RUN(test_verify_random_corruption);
    RUN(test_clusters);
    return check_summary();
}
