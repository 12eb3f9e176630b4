/* Unit tests for src/sha256: the FIPS 180-2 example digests, padding at every
 * block boundary (digests from Python's hashlib, an independent
 * implementation), streaming in any split equal to one call, and file hashing. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "sha256.h"

static void hex_of(const void *bytes, size_t size, char hex[SHA256_HEX])
{
    uint8_t d[SHA256_BYTES];
    sha256_bytes(bytes, size, d);
    sha256_hex(d, hex);
}

static void fips_examples(void)
{
    char hex[SHA256_HEX];
    hex_of("abc", 3, hex);
    CHECK(strcmp(hex, "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad") == 0, "abc: %s", hex);
    hex_of("", 0, hex);
    CHECK(strcmp(hex, "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855") == 0, "empty: %s", hex);
    const char *two = "abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq";
    hex_of(two, strlen(two), hex);
    CHECK(strcmp(hex, "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1") == 0, "two blocks: %s", hex);
    /* one million 'a', fed in uneven pieces */
    char chunk[997];
    memset(chunk, 'a', sizeof chunk);
    sha256_ctx ctx;
    sha256_init(&ctx);
    size_t left = 1000000;
    while (left) {
        size_t n = left < sizeof chunk ? left : sizeof chunk;
        sha256_update(&ctx, chunk, n);
        left -= n;
    }
    uint8_t d[SHA256_BYTES];
    sha256_final(&ctx, d);
    sha256_hex(d, hex);
    CHECK(strcmp(hex, "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0") == 0, "million a: %s", hex);
}

/* Lengths around the 56-byte padding limit and the 64-byte block. */
static void block_boundaries(void)
{
    static const struct {
        size_t n;
        const char *hex;
    } kCases[] = {
        {55, "e7313d333c272e639f790978283f9eb392e843d0f29b7016828bb1daa4aac70b"},
        {56, "4324d65f3c103567f5589c710bc08f8523f929a9272e3af36fc968e52abc6c27"},
        {57, "35df609437dcfea3279283ab79fd554e2bf78f8f7ae2de532d8ee300b09e8f73"},
        {63, "81c80242132f230c3bd41b3e63bbcff16107339549214a99614ff26664625055"},
        {64, "39e3d7b6b5d075d37d053ad89b24b41bef4f3c29760c84447cab3f3be1882241"},
        {65, "aacca6ff74fdbb296d165a45cecfa04e5127bc008770fbbdd48006f2d2fae95e"},
        {119, "9ce7368e4daf32341631b492e80359dc9f594b48453cd0dd5bf0b19279cc177e"},
        {120, "7836b787757e95e58b3ca5aec90b1b004e8deba1e50e9675af9cabf1a13a04b5"},
    };
    uint8_t bytes[128];
    for (size_t i = 0; i < sizeof bytes; ++i) bytes[i] = (uint8_t)(i * 7 + 3);
    for (size_t c = 0; c < sizeof kCases / sizeof kCases[0]; ++c) {
        char hex[SHA256_HEX];
        hex_of(bytes, kCases[c].n, hex);
        CHECK(strcmp(hex, kCases[c].hex) == 0, "length %zu: %s", kCases[c].n, hex);
    }
}

/* Every split of a 150-byte message into two updates (and byte by byte) gives
 * the one-call digest. */
static void streaming_equals_one_call(void)
{
    uint8_t bytes[150];
    for (size_t i = 0; i < sizeof bytes; ++i) bytes[i] = (uint8_t)(i * 31 + 11);
    uint8_t whole[SHA256_BYTES], part[SHA256_BYTES];
    sha256_bytes(bytes, sizeof bytes, whole);
    int mismatches = 0;
    for (size_t cut = 0; cut <= sizeof bytes; ++cut) {
        sha256_ctx ctx;
        sha256_init(&ctx);
        sha256_update(&ctx, bytes, cut);
        sha256_update(&ctx, bytes + cut, sizeof bytes - cut);
        sha256_final(&ctx, part);
        if (memcmp(whole, part, SHA256_BYTES) != 0) mismatches++;
    }
    CHECK(mismatches == 0, "%d splits differ", mismatches);
    sha256_ctx ctx;
    sha256_init(&ctx);
    for (size_t i = 0; i < sizeof bytes; ++i) sha256_update(&ctx, bytes + i, 1);
    sha256_final(&ctx, part);
    CHECK(memcmp(whole, part, SHA256_BYTES) == 0, "byte-by-byte digest differs");
}

static void file_digest(void)
{
    char path[] = "/tmp/lodpipe-sha256-XXXXXX";
    int fd = mkstemp(path);
    CHECK(fd >= 0, "mkstemp");
    if (fd < 0) return;
    CHECK(write(fd, "abc", 3) == 3, "write");
    close(fd);
    char hex[SHA256_HEX];
    CHECK(sha256_file_hex(path, hex) == 0, "hash the file");
    CHECK(strcmp(hex, "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad") == 0, "file: %s", hex);
    unlink(path);
    CHECK(sha256_file_hex(path, hex) == -1, "a missing file is an error");
}

int main(void)
{
    RUN(fips_examples);
    RUN(block_boundaries);
    RUN(streaming_equals_one_call);
    RUN(file_digest);
    return check_summary();
}
