/* version.h - the tool's version; part of every cache key later on. */
#ifndef LODPIPE_VERSION_H
#define LODPIPE_VERSION_H
#define LODPIPE_VERSION "0.1.0"
#endif
