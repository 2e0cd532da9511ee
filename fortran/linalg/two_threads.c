/* two_threads.c: two work items, the second offered to a helper thread (ldl_solves'
 * two-thread triangular solves: the two subtrees under the top separator).
 *
 * dc_two_items(fn, ctx) runs fn(ctx, 1) in the calling thread and offers fn(ctx, 2) to
 * one helper thread of the process (created at the first call, then asleep between
 * calls). If the helper has not taken item 2 by the time the caller is done with item 1
 * (no free CPU: the machine is busy), the caller runs item 2 itself. So a busy machine
 * costs the serial time plus a wake-up, never a wait for a time slice of a thread that
 * is not running (an OpenMP team's barrier waits for every thread of the team: measured
 * 11x slower than serial at 32 800 dofs under a load of 4 on 2 cores). Which thread
 * runs item 2 does not change the results: the same code on the same data.
 *
 * One call at a time uses the helper (another thread of the process calling meanwhile
 * runs both items itself). A fork of the process has no helper (threads do not survive
 * fork()): there both items run in the caller. The statics below are the process's one
 * helper and its mailbox. */
#include <pthread.h>
#include <sched.h>
#include <stdatomic.h>
#include <sys/types.h>
#include <unistd.h>

typedef void (*dc_item_fn)(void *ctx, int item);

enum { ITEM_IDLE = 0, ITEM_POSTED = 1, ITEM_CLAIMED = 2, ITEM_DONE = 3 };

static pthread_mutex_t call_mu = PTHREAD_MUTEX_INITIALIZER;  /* one call at a time */
static pthread_mutex_t wake_mu = PTHREAD_MUTEX_INITIALIZER;  /* guards posted */
static pthread_cond_t wake_cv = PTHREAD_COND_INITIALIZER;
static unsigned long posted = 0;          /* items posted so far (wakes the helper) */
static _Atomic int state = ITEM_IDLE;     /* item 2's state */
static dc_item_fn job_fn;                 /* item 2: written before state = POSTED */
static void *job_ctx;
static pid_t helper_pid = 0;              /* the process whose helper runs; 0: none yet */

static void *helper_main(void *arg) {
    unsigned long seen = 0;
    (void)arg;
    for (;;) {
        pthread_mutex_lock(&wake_mu);
        while (posted == seen) pthread_cond_wait(&wake_cv, &wake_mu);
        seen = posted;
        pthread_mutex_unlock(&wake_mu);
        int expect = ITEM_POSTED;
        if (atomic_compare_exchange_strong(&state, &expect, ITEM_CLAIMED)) {
            job_fn(job_ctx, 2);
            atomic_store_explicit(&state, ITEM_DONE, memory_order_release);
        }
    }
    return NULL;
}

/* 1 when this process has (or may start) the helper: not a fork of a process that had
 * started one. */
int dc_two_usable(void) { return helper_pid == 0 || helper_pid == getpid(); }

/* Run fn(ctx, 1) and fn(ctx, 2), the second on the helper thread when it takes it in
 * time (see above). Returns 2 when the helper ran item 2, 1 when the caller ran both. */
int dc_two_items(dc_item_fn fn, void *ctx) {
    int by = 1;
    if (!dc_two_usable() || pthread_mutex_trylock(&call_mu) != 0) {
        fn(ctx, 1);
        fn(ctx, 2);
        return 1;
    }
    if (helper_pid == 0) {
        pthread_t t;
        pthread_attr_t attr;
        int ok = pthread_attr_init(&attr) == 0;
        if (ok) ok = pthread_attr_setdetachstate(&attr, PTHREAD_CREATE_DETACHED) == 0;
        if (ok) ok = pthread_create(&t, &attr, helper_main, NULL) == 0;
        pthread_attr_destroy(&attr);
        if (!ok) {
            pthread_mutex_unlock(&call_mu);
            fn(ctx, 1);
            fn(ctx, 2);
            return 1;
        }
        helper_pid = getpid();
    }
    job_fn = fn;
    job_ctx = ctx;
    atomic_store_explicit(&state, ITEM_POSTED, memory_order_release);
    pthread_mutex_lock(&wake_mu);
    posted++;
    pthread_cond_signal(&wake_cv);
    pthread_mutex_unlock(&wake_mu);
    fn(ctx, 1);
    int expect = ITEM_POSTED;
    if (atomic_compare_exchange_strong(&state, &expect, ITEM_CLAIMED)) {
        fn(ctx, 2);          /* the helper did not start it: do it here */
    } else {
        by = 2;              /* the helper runs it: wait (it is running, or was) */
        for (long spins = 0; atomic_load_explicit(&state, memory_order_acquire) != ITEM_DONE;
             spins++) {
            if (spins > 1000) sched_yield();
        }
    }
    atomic_store_explicit(&state, ITEM_IDLE, memory_order_relaxed);
    pthread_mutex_unlock(&call_mu);
    return by;
}
