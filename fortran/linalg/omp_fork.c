/* omp_fork.c: whether this process may start OpenMP threads (ldl_solves' two-thread
 * triangular solve). GNU libgomp keeps its worker threads for the next parallel region,
 * and they do not survive fork(): a child forked by a process that had started them (a
 * multiprocessing or concurrent.futures pool on Linux, after a run on two threads in the
 * parent) would wait for them for ever at its first parallel region. So the pid of the
 * process that first starts them is kept, and any other process (a fork of it) solves
 * on one thread. The one static is a fact of the process, written once (two threads
 * racing to write it write the same value). */
#include <sys/types.h>
#include <unistd.h>

static volatile pid_t dc_omp_pid = 0;  /* the process that started OpenMP threads; 0: none */

/* 1 when this process may start OpenMP threads: none were started yet, or by itself. */
int dc_omp_usable(void) { return dc_omp_pid == 0 || dc_omp_pid == getpid(); }

/* Called before a parallel region: this process starts (or has started) OpenMP threads. */
void dc_omp_starting(void) {
    if (dc_omp_pid == 0) dc_omp_pid = getpid();
}
