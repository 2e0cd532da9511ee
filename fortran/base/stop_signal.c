/* stop_signal.c: the process's stop flag, the number of the last SIGINT / SIGTERM that
 * the handler dc_on_stop_signal caught (0 = none). run_guard.c installs that handler:
 * for the whole run in the executable (dc_signals_install), and only over the core's
 * call that opens a run in a Python caller's process (dc_stop_signals_catch, then the
 * caller's own handlers are put back and the flag taken, dc_stop_signal_take). The time
 * loop reads the flag before each step, and a run's set-up between its phases and in its
 * long loops (the assembly's chunks of cells, the orderings tried, the ranges of rows of
 * a simplicial factorization, the power iterations, the groups of contact columns), so
 * that a stop signal ends the set-up within a fraction of a second of its work. The one
 * flag of the process: set only by the handler, cleared only by dc_stop_signal_take. */
#include <signal.h>

static volatile sig_atomic_t dc_signal_flag = 0;

/* The handler: records the signal, nothing else (async-signal-safe). */
void dc_on_stop_signal(int sig) { dc_signal_flag = sig; }

/* The signal caught (0 = none). */
int dc_signal_caught(void) { return (int) dc_signal_flag; }

/* The signal caught (0 = none), and the flag cleared: a Python caller's process, whose
 * own handlers take the signal over again after the open. */
int dc_stop_signal_take(void)
{
    int sig = (int) dc_signal_flag;
    dc_signal_flag = 0;
    return sig;
}
