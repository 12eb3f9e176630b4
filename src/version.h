/* version.h - the tool's version, and LODPIPE_SOURCE_ID (source_id.h, made by
 * the Makefile): a hash of lodpipe's own source files. Both go into every
 * batch cache key: a rebuilt lodpipe with the same version number but other
 * code must not reuse outputs the old one wrote. */
#ifndef LODPIPE_VERSION_H
#define LODPIPE_VERSION_H
#include "source_id.h"
#define LODPIPE_VERSION "0.1.0"
#endif
