/* sha256.h - SHA-256 (FIPS 180-4), the hash behind lodpipe's cache keys.
 *
 * A streaming hasher: sha256_init, any number of sha256_update calls, then
 * sha256_final gives the 32-byte digest of the concatenated bytes. The result
 * is the standard SHA-256 (the unit test checks the FIPS 180-2 examples), so a
 * key can be recomputed with any other tool. No global state: distinct
 * contexts may be used on different threads. */
#ifndef LODPIPE_SHA256_H
#define LODPIPE_SHA256_H

#include <stddef.h>
#include <stdint.h>

#define SHA256_BYTES 32
#define SHA256_HEX (2 * SHA256_BYTES + 1) /* hex text with its terminator */

typedef struct sha256_ctx {
    uint32_t state[8];
    uint64_t length;    /* bytes hashed so far */
    uint8_t block[64];  /* pending bytes of the current block */
    size_t block_used;
} sha256_ctx;

void sha256_init(sha256_ctx *ctx);
void sha256_update(sha256_ctx *ctx, const void *bytes, size_t size);
/* Writes the digest; the context must be re-initialised before reuse. */
void sha256_final(sha256_ctx *ctx, uint8_t digest[SHA256_BYTES]);

/* The digest of one byte string. */
void sha256_bytes(const void *bytes, size_t size, uint8_t digest[SHA256_BYTES]);

/* The digest as 64 lowercase hex digits plus a terminator. */
void sha256_hex(const uint8_t digest[SHA256_BYTES], char hex[SHA256_HEX]);

/* Hashes the file at path into hex. Returns 0, or -1 when it cannot be read
 * (errno tells why). */
int sha256_file_hex(const char *path, char hex[SHA256_HEX]);

#endif
