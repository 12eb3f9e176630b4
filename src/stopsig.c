/* stopsig.c - see stopsig.h. */
#include "stopsig.h"

#include <pthread.h>
#include <string.h>

static const int kStopSignals[STOPSIG_COUNT] = {SIGINT, SIGTERM, SIGHUP};

void stopsig_catch(void (*handler)(int), stopsig_saved *saved)
{
    for (int k = 0; k < STOPSIG_COUNT; ++k) {
        /* an ignored signal stays ignored: a background job of a
         * non-interactive shell ignores SIGINT, and Ctrl-C at that terminal
         * is not meant for it (nohup: SIGHUP likewise) */
        sigaction(kStopSignals[k], NULL, &saved->before[k]);
        if (saved->before[k].sa_handler == SIG_IGN) continue;
        struct sigaction sa;
        memset(&sa, 0, sizeof sa);
        sa.sa_handler = handler;
        sigemptyset(&sa.sa_mask);
        sigaction(kStopSignals[k], &sa, NULL);
    }
}

void stopsig_block(sigset_t *old)
{
    sigset_t stops;
    sigemptyset(&stops);
    for (int k = 0; k < STOPSIG_COUNT; ++k) sigaddset(&stops, kStopSignals[k]);
    pthread_sigmask(SIG_BLOCK, &stops, old);
}

void stopsig_restore(const stopsig_saved *saved)
{
    for (int k = 0; k < STOPSIG_COUNT; ++k) sigaction(kStopSignals[k], &saved->before[k], NULL);
}
