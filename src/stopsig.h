/* stopsig.h - the signals that ask lodpipe to stop (SIGINT, SIGTERM, SIGHUP:
 * Ctrl-C, kill, a CI job's timeout, a closed terminal), caught for a while by
 * code that must clean up first: the writer removes its temp files, the
 * batch stops its jobs. stopsig_catch installs `handler` for each of them
 * that is not ignored (no SA_RESTART: a blocking call returns EINTR) and
 * saves what was there; stopsig_restore puts that back. */
#ifndef LODPIPE_STOPSIG_H
#define LODPIPE_STOPSIG_H

#include <signal.h>

#define STOPSIG_COUNT 3

typedef struct stopsig_saved {
    struct sigaction before[STOPSIG_COUNT];
} stopsig_saved;

void stopsig_catch(void (*handler)(int), stopsig_saved *saved);
void stopsig_restore(const stopsig_saved *saved);

/* Blocks all of them in the calling thread's mask (pthread_sigmask), the
 * mask before in *old: a stop then waits until the mask is put back. */
void stopsig_block(sigset_t *old);

#endif
