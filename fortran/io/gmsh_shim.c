/* gmsh_shim.c: meshes read through gmsh's own C API (libgmsh), loaded at run time.
 *
 * libgmsh is large (about 90 MB): it is dlopen()ed by the first call that names a mesh
 * file, never at start-up, so a run on a built-in mesh does not map it. Where it is looked
 * for: $DYNCONTACT_GMSH_LIB alone when it is set; otherwise in the environment this code is
 * installed in (lib/libgmsh.so* in the folder of the executable or extension module that
 * holds it and in its four parents: the gmsh wheel puts the library in <venv>/lib, the
 * executable is <venv>/bin/dyncontact and the extension
 * <venv>/lib/pythonX.Y/site-packages/dyncontact/_core*.so), then the library found by meson
 * at build time (DC_GMSH_LIB), then the dynamic loader's own search (libgmsh.so.<version>,
 * libgmsh.so). The build needs no gmsh: the functions' signatures are in gmsh_api.h.
 * A build with gmsh disabled (DC_WITH_GMSH undefined) still compiles: every call then
 * reports that mesh files need gmsh.
 *
 * dc_gmsh_read() loads a file (msh 2.2 / 4.x, ASCII or binary, or a .geo meshed in-process
 * with the parameters h, length, width) and applies the project's conventions
 * (docs/scenes.md, python/dyncontact/mesh_io.py):
 *   - nodes: all nodes of the file (of the kept cells for a .geo), by increasing tag;
 *   - dim: the highest dimension with elements; cells: elements of dimension dim, by entity
 *     (increasing tag), in the entity's order, with the first physical group of the entity;
 *   - facets: elements of dimension dim - 1 of entities with physical groups, once per group;
 *   - lower nodes: the nodes of the elements of dimension below dim - 1 (points; 2-node
 *     segments of curves in 3D) of entities with physical groups, once per (group, node),
 *     sorted by group then node: what a Physical Point or Curve holds that no facet does;
 *   - groups: the named physical groups by (dimension, tag) -- the order of $PhysicalNames in
 *     every file gmsh writes --, then the unnamed ones in order of first use by an entity.
 * The result (1-based indices) is copied by the Fortran module gmsh_mesh, then freed with
 * dc_gmsh_free(). gmsh state: initialized and finalized around the read; if the process
 * already runs gmsh (the Python gmsh module), a model is added and removed, the options
 * and parser variables set here are restored, and its ONELAB database is set aside during
 * the read and put back as it was (onelab_empty). Terminal output is off
 * (General.Terminal 0).
 * Signals: loading libgmsh and gmsh's initialization and finalization install or reset
 * handlers (seen with gmsh 4.15: SIGHUP, SIGQUIT, SIGBUS, SIGFPE, SIGSEGV, SIGPIPE and
 * SIGTERM are no longer caught after a read), which would take SIGTERM away from the run's
 * own handler (run_guard.c) or Python's. Every call that enters gmsh therefore saves the
 * dispositions of all signals and restores them afterwards, and holds the stop signals
 * (SIGINT, SIGTERM, SIGHUP, SIGQUIT) blocked meanwhile, so that one sent during the read is
 * delivered, to the caller's handler, once the read is over. In the executable (its
 * handlers installed, run_guard.c), a read or meshing may take minutes and nothing has
 * been written yet: there a thread waits for SIGINT / SIGTERM during dc_gmsh_read and
 * ends the process at once (exit 130, one line naming the file), so Ctrl-C does not wait
 * for gmsh to finish. A program that runs in a Python process (`python -m dyncontact
 * run` and `mesh`) asks for the same with dc_exit_on_read_signal (run_guard.c); a library
 * caller never does, and keeps the signal until the read is over. Before it ends the
 * process, the stop removes the temporary files the program named (dc_stop_removes).
 * A signal the process ignores when the read starts stays ignored. The Python gmsh
 * module's own calls (mesh_io.generate) get the same guard through dc_gmsh_guard_begin,
 * dc_gmsh_guard_after_init and dc_gmsh_guard_end.
 * Status: 0 ok, 2 bad input (message in msg), 4 out of memory, 5 a .geo estimated above
 * the element limit (not meshed; see geo_estimate). */
#define _GNU_SOURCE   /* strcasestr */
#include <dlfcn.h>
#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <glob.h>
#include <limits.h>
#include <strings.h>
#include <unistd.h>
#ifdef DC_WITH_GMSH
#ifdef DC_GMSHC_CHECK
#include <gmshc.h>   /* the compiler checks gmsh_api.h's signatures against gmsh's own */
#endif
#include "gmsh_api.h"
#endif

#ifndef DC_GMSH_LIB
#define DC_GMSH_LIB ""
#endif

/* The mesh handed to Fortran (1-based node numbers and group indices, 0 = no group). */
typedef struct {
    int dim, n_groups;
    size_t n_nodes, n_cells, n_facets;
    double *xyz;           /* 3 * n_nodes */
    int *cells;            /* (dim + 1) * n_cells */
    int *cell_group;       /* n_cells */
    int *facets;           /* dim * n_facets */
    int *facet_group;      /* n_facets */
    int *group_dim;        /* n_groups */
    char *group_names;     /* n_groups names, each followed by '\n' */
    size_t n_lower;        /* (group, node) pairs of the groups below dimension dim - 1 */
    int *lower_nodes;      /* n_lower node numbers */
    int *lower_group;      /* n_lower group indices */
} dc_gmsh_mesh_t;

#define NO_GMSH_MSG "mesh files need gmsh (libgmsh): install it with `pip install gmsh` " \
    "into the environment dyncontact is installed in (scripts/setup does), or set " \
    "DYNCONTACT_GMSH_LIB to the path of libgmsh.so"
#define NO_GMSH_BUILD_MSG "mesh files need gmsh, and this build has it disabled (meson " \
    "option gmsh=disabled): rebuild without that option"

/* The dispositions of every signal and the calling thread's signal mask, saved before a
 * call into gmsh and restored after it (see the header). */
typedef struct {
    struct sigaction action[NSIG];
    unsigned char saved[NSIG];
    sigset_t mask;
} signal_state_t;

static void signals_save(signal_state_t *s)
{
    sigset_t stop;
    int sig;
    for (sig = 1; sig < NSIG; sig++)
        s->saved[sig] = sig != SIGKILL && sig != SIGSTOP
                        && sigaction(sig, NULL, &s->action[sig]) == 0;
    sigemptyset(&stop);
    sigaddset(&stop, SIGINT);
    sigaddset(&stop, SIGTERM);
    sigaddset(&stop, SIGHUP);
    sigaddset(&stop, SIGQUIT);
    pthread_sigmask(SIG_BLOCK, &stop, &s->mask);
}

static void signals_restore(const signal_state_t *s)
{
    int sig;
    for (sig = 1; sig < NSIG; sig++)
        if (s->saved[sig]) sigaction(sig, &s->action[sig], NULL);
    pthread_sigmask(SIG_SETMASK, &s->mask, NULL);
}

int dc_read_signal_exits(void);   /* run_guard.c */

/* A stop armed by stop_watch_start: armed = 1 when this read armed it, running = 1 when
 * its thread (stop_watch_main) runs. */
typedef struct {
    pthread_t thread;
    int armed, running;
} stop_watch_t;

/* The line said when a stop signal ends a read, around the signal's number ("dyncontact:
 * FILE: interrupted by signal " and STOP_TAIL), and whether a stop is armed: process
 * state, written before the handler of stop_arm_handlers is installed and read by it,
 * since a signal handler gets no argument. One read at a time is armed (the executable
 * and the Python command line read one mesh at a time); a read started meanwhile in
 * another thread, or inside a guard (dc_gmsh_guard_begin) that armed one, arms none. */
static char stop_head[4096];
static size_t stop_head_len;
static char stop_tail[512];
static size_t stop_tail_len;
static volatile sig_atomic_t stop_armed = 0;

/* The stop signals, and those of them that end an armed read: not one the process
 * ignores when the read starts (SIG_IGN: `nohup`, a background job of a shell without job
 * control), which stays ignored. */
static const int STOP_SIGNALS[2] = {SIGINT, SIGTERM};
static int stop_ends[2];

#define STOP_TAIL " while gmsh read it; nothing was written"

/* The files and folders that a stop during a gmsh read removes before it ends the process
 * (dc_stop_remove_all, called by stop_exit): a program's temporary files written before
 * the read (`python -m dyncontact run --set` writes its scene there, `dyncontact mesh` its
 * mesh file until it is whole). A fixed table, so that the handler reads it without a
 * lock or an allocation: a path is copied into a free slot before the slot is marked
 * used, and the slot is marked free before it is reused. */
#define STOP_REMOVE_SLOTS 8
#define STOP_REMOVE_PATH 4096
static char stop_remove_path[STOP_REMOVE_SLOTS][STOP_REMOVE_PATH];
static volatile sig_atomic_t stop_remove_used[STOP_REMOVE_SLOTS];
static pthread_mutex_t stop_remove_lock = PTHREAD_MUTEX_INITIALIZER;

/* Name path (a file or an empty folder) to be removed by a stop during a gmsh read, until
 * dc_stop_keeps(path). 0, ENAMETOOLONG (an empty path or one too long) or ENOSPC (every
 * slot in use). */
int dc_stop_removes(const char *path)
{
    size_t n = strlen(path);
    int i, err = ENOSPC;
    if (n == 0 || n >= STOP_REMOVE_PATH) return ENAMETOOLONG;
    pthread_mutex_lock(&stop_remove_lock);
    for (i = 0; i < STOP_REMOVE_SLOTS; i++) {
        if (stop_remove_used[i]) continue;
        memcpy(stop_remove_path[i], path, n + 1);
        __atomic_thread_fence(__ATOMIC_SEQ_CST);   /* the path before the mark */
        stop_remove_used[i] = 1;
        err = 0;
        break;
    }
    pthread_mutex_unlock(&stop_remove_lock);
    return err;
}

/* Take back one naming of path by dc_stop_removes (the file is kept, or removed by its
 * writer itself); a path not named is ignored. */
void dc_stop_keeps(const char *path)
{
    int i;
    pthread_mutex_lock(&stop_remove_lock);
    for (i = 0; i < STOP_REMOVE_SLOTS; i++)
        if (stop_remove_used[i] && strcmp(stop_remove_path[i], path) == 0) {
            stop_remove_used[i] = 0;
            break;
        }
    pthread_mutex_unlock(&stop_remove_lock);
}

/* Remove the files, then the (then empty) folders, named by dc_stop_removes. Only
 * async-signal-safe calls (unlink, rmdir): the stop's signal handler calls it right
 * before _exit. */
void dc_stop_remove_all(void)
{
    int i, saved = errno;
    for (i = 0; i < STOP_REMOVE_SLOTS; i++)
        if (stop_remove_used[i]) (void)unlink(stop_remove_path[i]);
    for (i = STOP_REMOVE_SLOTS - 1; i >= 0; i--)
        if (stop_remove_used[i]) (void)rmdir(stop_remove_path[i]);
    errno = saved;
}

/* Remove what the program named to be removed on a stop (dc_stop_removes: its temporary
 * files), say that signal sig interrupted the read, in one line on stderr, and end the
 * process with 130, the status of an interrupted run. Only async-signal-safe calls
 * (unlink, rmdir, write, _exit): a signal handler calls it too. */
static void stop_exit(int sig)
{
    char num[16];
    int i = (int)sizeof num;
    ssize_t w;
    dc_stop_remove_all();
    do { num[--i] = (char)('0' + sig % 10); sig /= 10; } while (sig > 0 && i > 0);
    w = write(STDERR_FILENO, stop_head, stop_head_len);
    w = write(STDERR_FILENO, num + i, sizeof num - (size_t)i);
    w = write(STDERR_FILENO, stop_tail, stop_tail_len);
    w = write(STDERR_FILENO, "\n", 1);
    (void)w;
    _exit(130);
}

static void stop_on_signal(int sig) { stop_exit(sig); }

/* Point SIGINT and SIGTERM (those of stop_ends) at stop_on_signal while a stop is armed. The thread of
 * stop_watch_main alone does not do: a signal sent to the process goes to any one of its
 * threads that does not block it, and a Python process has such threads (OpenBLAS's
 * workers, started when numpy is imported, before the read blocks the signals in its own
 * thread); there the disposition decides, which would be Python's handler (a flag, seen
 * once gmsh returns) or, for SIGTERM once gmsh's initialization has reset it, the default
 * (killed without a line). Called when the stop is armed, and again after gmsh's
 * initialization (gmsh_read). */
static void stop_arm_handlers(void)
{
    struct sigaction sa;
    int i;
    if (!stop_armed) return;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = stop_on_signal;
    sigemptyset(&sa.sa_mask);
    sigaddset(&sa.sa_mask, SIGINT);
    sigaddset(&sa.sa_mask, SIGTERM);
    for (i = 0; i < 2; i++)
        if (stop_ends[i]) sigaction(STOP_SIGNALS[i], &sa, NULL);
}

/* The stop signals' dispositions after gmsh's initialization, which resets SIGTERM,
 * SIGHUP and SIGQUIT to their defaults, as they must be during the read in the threads
 * that do not block them (a Python process has such threads, see stop_arm_handlers):
 * the stop's handlers where one is armed, else the caller's own, saved in s by
 * signals_save. Without this a library caller's SIGTERM during the first read reaches one
 * of those threads with the default disposition and kills the process, instead of
 * reaching the caller's handler once the read is over. */
static void stop_signals_after_init(const signal_state_t *s)
{
    static const int stop[] = {SIGINT, SIGTERM, SIGHUP, SIGQUIT};
    size_t i;
    for (i = 0; i < sizeof stop / sizeof stop[0]; i++)
        if (s->saved[stop[i]]) sigaction(stop[i], &s->action[stop[i]], NULL);
    stop_arm_handlers();
}

/* Wait for SIGINT or SIGTERM (those of stop_ends; blocked in the reading thread, so they
 * stay pending until taken here or by another thread's stop_on_signal), then stop_exit. The one thread of
 * the executable that does not block them during a read. */
static void *stop_watch_main(void *arg)
{
    sigset_t stop;
    int sig = 0, i;
    (void)arg;
    sigemptyset(&stop);
    for (i = 0; i < 2; i++)
        if (stop_ends[i]) sigaddset(&stop, STOP_SIGNALS[i]);
    if (sigwait(&stop, &sig) != 0) return NULL;
    stop_exit(sig);
    return NULL;
}

/* Copy text into buf (size bytes), cut to fit; its length. */
static size_t stop_text(char *buf, size_t size, const char *text)
{
    int n = snprintf(buf, size, "%s", text);
    if (n < 0) { buf[0] = '\0'; return 0; }
    return (size_t)n < size ? (size_t)n : size - 1;
}

/* In the executable, or a program that asked for it (dc_exit_on_read_signal, run_guard.c:
 * `python -m dyncontact run` and `mesh`), arm the stop, whose line is head, the signal's
 * number and tail: the line, the handlers of stop_arm_handlers and the thread of
 * stop_watch_main (the stop signals are blocked in this thread already by signals_save,
 * and the dispositions it saved are put back by signals_restore); elsewhere (a library
 * caller) nothing. */
static void stop_watch_start(stop_watch_t *w, const char *head, const char *tail)
{
    struct sigaction current;
    int i, any = 0;
    w->armed = w->running = 0;
    if (!dc_read_signal_exits() || stop_armed) return;
    for (i = 0; i < 2; i++) {
        stop_ends[i] = sigaction(STOP_SIGNALS[i], NULL, &current) == 0
                       && ((current.sa_flags & SA_SIGINFO) || current.sa_handler != SIG_IGN);
        any = any || stop_ends[i];
    }
    if (!any) return;
    stop_head_len = stop_text(stop_head, sizeof stop_head, head);
    stop_tail_len = stop_text(stop_tail, sizeof stop_tail, tail);
    stop_armed = w->armed = 1;
    stop_arm_handlers();
    w->running = pthread_create(&w->thread, NULL, stop_watch_main, NULL) == 0;
}

/* End the thread of stop_watch_start and disarm, before signals_restore puts the
 * dispositions and the mask back, so that a signal sent after the read goes to the run's
 * handler as before. */
static void stop_watch_end(stop_watch_t *w)
{
    if (w->running) {
        pthread_cancel(w->thread);   /* sigwait is a cancellation point */
        pthread_join(w->thread, NULL);
    }
    if (w->armed) stop_armed = 0;
    w->armed = w->running = 0;
}

/* A guard around a program's own calls into gmsh that do not go through dc_gmsh_read:
 * the Python gmsh module of `python -m dyncontact mesh`, which parses, meshes and writes a
 * .geo (python/dyncontact/mesh_io.py). Within it, as within dc_gmsh_read: the stop
 * signals are blocked in the calling thread, the dispositions of every signal are saved
 * at dc_gmsh_guard_begin and put back at dc_gmsh_guard_end (those that gmsh's
 * initialization resets, SIGTERM among them, and a SIGTERM ignored from the program's
 * start, which would otherwise end the process), and dc_gmsh_guard_after_init, called
 * right after gmsh's initialization, puts the stop signals' dispositions back at once;
 * in a program that asked for it (dc_exit_on_read_signal), SIGINT / SIGTERM end the
 * process at once with exit status 130, after removing what dc_stop_removes names (the
 * mesh file being written), saying line_start, the signal's number and line_end. A
 * library caller keeps the signal until the guard ends. One guard at a time, held by
 * the thread that began it (a Python thread of the process); a begin meanwhile returns 0
 * and guards nothing, and a dc_gmsh_read inside arms no stop of its own (the guard's
 * line and files stand). Process state, since the Python code between the calls into
 * gmsh cannot carry it. */
static signal_state_t guard_sigs;
static stop_watch_t guard_watch;
static pthread_mutex_t guard_lock = PTHREAD_MUTEX_INITIALIZER;
static pthread_t guard_owner;
static int guard_held = 0;

/* 1 when the calling thread holds the guard. */
static int guard_mine(void)
{
    int mine;
    pthread_mutex_lock(&guard_lock);
    mine = guard_held && pthread_equal(guard_owner, pthread_self());
    pthread_mutex_unlock(&guard_lock);
    return mine;
}

/* Begin the guard (see above): 1, or 0 when another call holds it (nothing done). */
int dc_gmsh_guard_begin(const char *line_start, const char *line_end)
{
    pthread_mutex_lock(&guard_lock);
    if (guard_held) {
        pthread_mutex_unlock(&guard_lock);
        return 0;
    }
    guard_held = 1;
    guard_owner = pthread_self();
    pthread_mutex_unlock(&guard_lock);
    signals_save(&guard_sigs);
    stop_watch_start(&guard_watch, line_start, line_end);
    return 1;
}

/* Right after gmsh's initialization inside the guard: the stop signals' dispositions as
 * the guard found them, or the stop's handlers where it armed one. */
void dc_gmsh_guard_after_init(void)
{
    if (guard_mine()) stop_signals_after_init(&guard_sigs);
}

/* End the guard that the calling thread began (otherwise nothing): disarm its stop, put
 * back the dispositions and the thread's signal mask; a stop signal held meanwhile then
 * reaches the caller's handler. */
void dc_gmsh_guard_end(void)
{
    if (!guard_mine()) return;
    stop_watch_end(&guard_watch);
    signals_restore(&guard_sigs);
    pthread_mutex_lock(&guard_lock);
    guard_held = 0;
    pthread_mutex_unlock(&guard_lock);
}

static void set_msg(char *msg, int len, const char *a, const char *b, const char *c)
{
    if (len <= 0) return;
    snprintf(msg, (size_t)len, "%s%s%s", a, b ? b : "", c ? c : "");
}

/* The refusal of an entity of a physical group (dimension d, tag, the group's name) that
 * has no elements: `from_file` 0, a .geo meshed in-process, gmsh could not mesh it;
 * 1, a mesh file of cells of dimension `cells_dim` without it (saved at a lower
 * dimension when d > cells_dim, or an entity gmsh could not mesh). Without the path in
 * front (the caller names the file). The one wording of the core's reader and of
 * python/dyncontact/mesh_io.py (through dc_unmeshed_text). */
void dc_unmeshed_text(int d, int tag, const char *group, int cells_dim, int from_file,
                      char *out, int len)
{
    static const char *ent[4] = {"point", "curve", "surface", "volume"};
    static const char *noun[4] = {"points", "2-node segments", "3-node triangles",
                                  "4-node tetrahedra"};
    if (len <= 0) return;
    if (d < 0 || d > 3) d = 3;
    if (from_file && d > cells_dim)
        snprintf(out, (size_t)len, "%s %d of physical group '%s' has no %s in the file "
                 "(saved with gmsh -%d instead of -%d, or a %s gmsh could not mesh)", ent[d],
                 tag, group, noun[d], cells_dim, d, ent[d]);
    else if (from_file)
        snprintf(out, (size_t)len, "%s %d of physical group '%s' has no %s in the file (a %s "
                 "gmsh could not mesh)", ent[d], tag, group, noun[d], ent[d]);
    else
        snprintf(out, (size_t)len, "%s %d of physical group '%s' has no %s: gmsh could not "
                 "mesh it (a %s whose boundary crosses itself, say; gmsh retries such a %s "
                 "Mesh.MaxRetries times, 10 by default, which can take minutes: "
                 "Mesh.MaxRetries = 0 in the file gives up at once)", ent[d], tag, group,
                 noun[d], ent[d], ent[d]);
}

/* Path of the libgmsh this build would load ('' if none found); for messages and tests. */
void dc_gmsh_build_lib(char *out, int len)
{
    set_msg(out, len, DC_GMSH_LIB, NULL, NULL);
}

#ifndef DC_WITH_GMSH

int dc_gmsh_available(char *msg, int msglen)
{
    set_msg(msg, msglen, NO_GMSH_BUILD_MSG, 0, 0);
    return 0;
}

int dc_gmsh_read(const char *path, const double *params, int is_geo, void **out,
                 double est[4], char *msg, int msglen)
{
    (void)params; (void)is_geo; *out = NULL;
    est[0] = -1; est[1] = 0; est[2] = 0; est[3] = 0;
    set_msg(msg, msglen, path, ": ", NO_GMSH_BUILD_MSG);
    return 2;
}

int dc_gmsh_estimate(const char *path, const double *params, double est[4], char *msg,
                     int msglen)
{
    (void)params;
    est[0] = -1; est[1] = 0; est[2] = 0; est[3] = 0;
    set_msg(msg, msglen, path, ": ", NO_GMSH_BUILD_MSG);
    return 2;
}

#else

/* The gmshc functions used, resolved with dlsym. */
static struct {
    void *lib;
    __typeof__(&gmshInitialize) initialize;
    __typeof__(&gmshFinalize) finalize;
    __typeof__(&gmshIsInitialized) is_initialized;
    __typeof__(&gmshOptionSetNumber) option_set_number;
    __typeof__(&gmshOptionGetNumber) option_get_number;
    __typeof__(&gmshMerge) merge;
    __typeof__(&gmshModelAdd) model_add;
    __typeof__(&gmshModelRemove) model_remove;
    __typeof__(&gmshModelGetCurrent) model_get_current;
    __typeof__(&gmshModelSetCurrent) model_set_current;
    __typeof__(&gmshParserSetNumber) parser_set_number;
    __typeof__(&gmshParserGetNames) parser_get_names;
    __typeof__(&gmshParserClear) parser_clear;
    __typeof__(&gmshModelMeshGenerate) mesh_generate;
    __typeof__(&gmshModelGetDimension) get_dimension;
    __typeof__(&gmshModelMeshGetNodes) get_nodes;
    __typeof__(&gmshModelGetEntities) get_entities;
    __typeof__(&gmshModelMeshGetElements) get_elements;
    __typeof__(&gmshModelGetPhysicalGroups) get_physical_groups;
    __typeof__(&gmshModelGetPhysicalName) get_physical_name;
    __typeof__(&gmshModelGetPhysicalGroupsForEntity) get_physical_groups_for_entity;
    __typeof__(&gmshFree) free;
    __typeof__(&gmshLoggerGetLastError) last_error;
    __typeof__(&gmshLoggerWrite) logger_write;
    /* optional (the estimate of a .geo's element count; none: no estimate) */
    __typeof__(&gmshModelOccGetMass) occ_get_mass;
    __typeof__(&gmshOnelabClear) onelab_clear;
    __typeof__(&gmshOnelabGet) onelab_get;
    __typeof__(&gmshOnelabSet) onelab_set;
    __typeof__(&gmshModelGetBoundary) get_boundary;
    __typeof__(&gmshModelGetParametrizationBounds) get_parametrization_bounds;
    __typeof__(&gmshModelGetValue) get_value;
    __typeof__(&gmshModelMeshGetSizes) get_sizes;
    __typeof__(&gmshModelGetEntitiesForPhysicalGroup) get_entities_for_physical_group;
    __typeof__(&gmshModelGetType) get_type;
    __typeof__(&gmshOpen) open;
    __typeof__(&gmshParserGetNumber) parser_get_number;
    __typeof__(&gmshParserGetString) parser_get_string;
    __typeof__(&gmshParserSetString) parser_set_string;
} G;

static char load_error[512];

/* The libgmsh of the environment this code is installed in, in out ('' if none): the last
 * (highest version) lib/libgmsh.so* in the folder of the file that holds this code (the
 * executable, or the extension module in a Python process) or in one of its four parents. */
static void installed_gmsh(char *out, size_t len)
{
    Dl_info info;
    char dir[PATH_MAX], pattern[PATH_MAX + 32];
    int level;
    out[0] = '\0';
    if (!dladdr((void *)installed_gmsh, &info) || !info.dli_fname
            || !strchr(info.dli_fname, '/') || !realpath(info.dli_fname, dir)) {
        ssize_t n = readlink("/proc/self/exe", dir, sizeof dir - 1);
        if (n <= 0) return;
        dir[n] = '\0';
    }
    for (level = 0; level <= 4; level++) {
        char *slash = strrchr(dir, '/');
        glob_t found;
        if (!slash || slash == dir) return;   /* never / itself: the system's /lib */
        *slash = '\0';
        snprintf(pattern, sizeof pattern, "%s/lib/libgmsh.so*", dir);
        if (glob(pattern, 0, NULL, &found) == 0) {
            snprintf(out, len, "%s", found.gl_pathv[found.gl_pathc - 1]);
            globfree(&found);
            return;
        }
        globfree(&found);
    }
}

/* dlopen libgmsh once (the process keeps it); 1 if the functions are there. */
static int gmsh_load(void)
{
    const char *candidates[5];
    static char installed[PATH_MAX];
    int n = 0, i;
    if (G.lib) return 1;
    const char *env = getenv("DYNCONTACT_GMSH_LIB");
    if (env && *env) {
        candidates[n++] = env;
    } else {
        installed_gmsh(installed, sizeof installed);
        if (*installed) candidates[n++] = installed;
        if (*DC_GMSH_LIB) candidates[n++] = DC_GMSH_LIB;
#ifdef DC_GMSH_SOVERSION
        candidates[n++] = "libgmsh.so." DC_GMSH_SOVERSION;
#endif
        candidates[n++] = "libgmsh.so";
    }
    load_error[0] = '\0';
    for (i = 0; i < n && !G.lib; i++) {
        G.lib = dlopen(candidates[i], RTLD_NOW | RTLD_LOCAL);
        if (!G.lib && i == 0 && env && *env)
            snprintf(load_error, sizeof load_error, "DYNCONTACT_GMSH_LIB: %s", dlerror());
    }
    if (!G.lib) return 0;
#define SYM(field, name) \
    if (!(*(void **)&G.field = dlsym(G.lib, name))) { \
        snprintf(load_error, sizeof load_error, "libgmsh lacks %s", name); \
        dlclose(G.lib); G.lib = NULL; return 0; }
    SYM(initialize, "gmshInitialize") SYM(finalize, "gmshFinalize")
    SYM(is_initialized, "gmshIsInitialized") SYM(option_set_number, "gmshOptionSetNumber")
    SYM(option_get_number, "gmshOptionGetNumber") SYM(merge, "gmshMerge")
    SYM(model_add, "gmshModelAdd") SYM(model_remove, "gmshModelRemove")
    SYM(model_get_current, "gmshModelGetCurrent") SYM(model_set_current, "gmshModelSetCurrent")
    SYM(parser_set_number, "gmshParserSetNumber") SYM(parser_get_names, "gmshParserGetNames")
    SYM(parser_clear, "gmshParserClear") SYM(mesh_generate, "gmshModelMeshGenerate")
    SYM(get_dimension, "gmshModelGetDimension") SYM(get_nodes, "gmshModelMeshGetNodes")
    SYM(get_entities, "gmshModelGetEntities") SYM(get_elements, "gmshModelMeshGetElements")
    SYM(get_physical_groups, "gmshModelGetPhysicalGroups")
    SYM(get_physical_name, "gmshModelGetPhysicalName")
    SYM(get_physical_groups_for_entity, "gmshModelGetPhysicalGroupsForEntity")
    SYM(free, "gmshFree") SYM(last_error, "gmshLoggerGetLastError")
    SYM(logger_write, "gmshLoggerWrite")
#undef SYM
#define OPT(field, name) *(void **)&G.field = dlsym(G.lib, name);
    OPT(occ_get_mass, "gmshModelOccGetMass") OPT(get_boundary, "gmshModelGetBoundary")
    OPT(get_parametrization_bounds, "gmshModelGetParametrizationBounds")
    OPT(get_value, "gmshModelGetValue") OPT(get_sizes, "gmshModelMeshGetSizes")
    OPT(get_entities_for_physical_group, "gmshModelGetEntitiesForPhysicalGroup")
    OPT(get_type, "gmshModelGetType") OPT(onelab_clear, "gmshOnelabClear")
    OPT(onelab_get, "gmshOnelabGet") OPT(onelab_set, "gmshOnelabSet")
    OPT(open, "gmshOpen") OPT(parser_get_number, "gmshParserGetNumber")
    OPT(parser_get_string, "gmshParserGetString")
    OPT(parser_set_string, "gmshParserSetString")
#undef OPT
    return 1;
}

/* 1 if libgmsh can be loaded; otherwise 0 and why in msg. */
int dc_gmsh_available(char *msg, int msglen)
{
    signal_state_t sigs;
    int loaded;
    signals_save(&sigs);
    loaded = gmsh_load();
    signals_restore(&sigs);
    if (loaded) { set_msg(msg, msglen, "", 0, 0); return 1; }
    set_msg(msg, msglen, NO_GMSH_MSG, *load_error ? " (" : "", *load_error ? load_error : "");
    if (*load_error && msglen > 2 && strlen(msg) + 2 < (size_t)msglen) strcat(msg, ")");
    return 0;
}

/* gmsh's last error as "path: gmsh: <error>" in msg. */
static void gmsh_error(const char *path, const char *what, char *msg, int msglen)
{
    char *err = NULL;
    int ierr = 0;
    G.last_error(&err, &ierr);
    char buf[1024];
    snprintf(buf, sizeof buf, ": %s: %s", what,
             (ierr == 0 && err && *err) ? err : "gmsh failed without a message");
    /* one line of printable text */
    for (char *p = buf; *p; p++) if ((unsigned char)*p < 0x20 || *p == 0x7f) *p = ' ';
    set_msg(msg, msglen, path, buf, NULL);
    if (err) G.free(err);
}

/* Saved state of a gmsh session the caller already runs. */
typedef struct {
    int own;
    char *previous_model;
    double terminal, size_max;
    char **names_before;
    size_t n_names_before;
    char *onelab_before;     /* the caller's ONELAB database (JSON), restored at the end */
    int onelab_own;          /* 1: this read may empty the ONELAB database (onelab_empty) */
} session_t;

static const char *MODEL = "dyncontact-read";
static const char *PARAM_NAMES[3] = {"h", "length", "width"};

/* Empty the ONELAB database, so that a parse sees none of the parameters that an earlier
 * parse created (a DefineConstant with a Name takes the value of an existing ONELAB
 * parameter of that Name over its own: `DefineConstant[h = {0.02, Name "Mesh/h"}]` read
 * after a file that made "Mesh/h" 0.1 in the same gmsh session would mesh at 0.1), as
 * `gmsh file.geo` meshes it in a fresh process. Only where the database is this read's: a
 * session gmsh opened for it, or the caller's with its database set aside (session_begin)
 * and put back (session_end); a libgmsh without gmshOnelabGet/Set leaves it as it is. */
static void onelab_empty(const session_t *s)
{
    int ierr = 0;
    if (s->onelab_own) G.onelab_clear("", &ierr);
}

/* A parser variable of the caller's, kept across parse_bbox_reset. */
typedef struct {
    char *name;
    double *num;
    size_t n_num;
    char **str;
    size_t n_str;
} parser_var_t;

/* Make gmsh's parser forget the points of earlier parses, so that a .geo meshes to the
 * same bits whatever the process parsed before, as in a fresh process. While it parses,
 * gmsh takes its characteristic length (CTX lc, the scale of the tolerances of some of
 * its geometric operations) from the bounding box of every point parsed since its last
 * `open` of a file: a static of gmsh's that neither finalize and initialize, a new
 * model, nor gmshClear reset (seen with gmsh 4.15: meshes/disk.geo read after the same
 * file 1000 times larger had 177 of its 246 coordinates off in their last digits).
 * gmshOpen resets it; of an empty file (/dev/null), it parses nothing, but it also
 * clears the parser's variables, which are the caller's in a session the caller runs:
 * its numbers and strings are saved before and set again after (its macros and
 * SetFactory choice are not). The open empties the
 * current model, this read's, and takes its name: it is added again. A libgmsh without
 * gmshOpen or the parser's getters keeps that state. */
static void parse_bbox_reset(const session_t *s)
{
    int ierr = 0;
    size_t i, n = 0;
    char **names = NULL;
    parser_var_t *vars = NULL;
    if (!G.open || !G.parser_get_number || !G.parser_get_string || !G.parser_set_string)
        return;
    if (!s->own) {
        G.parser_get_names(&names, &n, "", &ierr);
        if (ierr) return;
        vars = calloc(n ? n : 1, sizeof *vars);
        if (!vars) {
            for (i = 0; i < n; i++) G.free(names[i]);
            if (names) G.free(names);
            return;
        }
        for (i = 0; i < n; i++) {
            vars[i].name = names[i];
            ierr = 0;
            G.parser_get_number(names[i], &vars[i].num, &vars[i].n_num, &ierr);
            ierr = 0;
            G.parser_get_string(names[i], &vars[i].str, &vars[i].n_str, &ierr);
        }
        if (names) G.free(names);
    }
    ierr = 0;
    G.open("/dev/null", &ierr);
    ierr = 0;
    G.model_remove(&ierr);
    ierr = 0;
    G.model_add(MODEL, &ierr);
    for (i = 0; i < n; i++) {
        ierr = 0;
        if (vars[i].n_str)
            G.parser_set_string(vars[i].name, (const char *const *)vars[i].str,
                                vars[i].n_str, &ierr);
        else
            G.parser_set_number(vars[i].name, vars[i].num, vars[i].n_num, &ierr);
        if (vars[i].num) G.free(vars[i].num);
        for (size_t j = 0; j < vars[i].n_str; j++) G.free(vars[i].str[j]);
        if (vars[i].str) G.free(vars[i].str);
        G.free(vars[i].name);
    }
    free(vars);
}

static int session_begin(session_t *s)
{
    int ierr = 0;
    memset(s, 0, sizeof *s);
    s->own = !G.is_initialized(&ierr);
    if (s->own) {
        char arg0[] = "dyncontact";
        char *argv[] = {arg0, NULL};
        G.initialize(1, argv, 0, 0, &ierr);
        if (ierr) return ierr;
    } else {
        G.model_get_current(&s->previous_model, &ierr);
        G.option_get_number("General.Terminal", &s->terminal, &ierr);
        G.option_get_number("Mesh.MeshSizeMax", &s->size_max, &ierr);
        G.parser_get_names(&s->names_before, &s->n_names_before, "", &ierr);
        /* the caller's ONELAB parameters, set aside for the read (onelab_empty) */
        if (G.onelab_get && G.onelab_set && G.onelab_clear) {
            ierr = 0;
            G.onelab_get(&s->onelab_before, "", "json", &ierr);
            if (ierr && s->onelab_before) { G.free(s->onelab_before); s->onelab_before = NULL; }
            ierr = 0;
        }
    }
    s->onelab_own = G.onelab_clear && (s->own || s->onelab_before);
    onelab_empty(s);
    G.option_set_number("General.Terminal", 0, &ierr);
    G.model_add(MODEL, &ierr);
    if (!ierr) parse_bbox_reset(s);
    return ierr;
}

/* Clear the parser variables created since session_begin. */
static void clear_new_names(const session_t *s)
{
    int ierr = 0;
    size_t i, j;
    char **names = NULL;
    size_t n = 0;
    G.parser_get_names(&names, &n, "", &ierr);
    for (i = 0; i < n; i++) {
        int seen = 0;
        for (j = 0; j < s->n_names_before && !seen; j++)
            seen = strcmp(names[i], s->names_before[j]) == 0;
        if (!seen) G.parser_clear(names[i], &ierr);
        G.free(names[i]);
    }
    if (names) G.free(names);
}

static void session_end(session_t *s)
{
    int ierr = 0;
    size_t j;
    if (s->own) { G.finalize(&ierr); return; }
    G.model_set_current(MODEL, &ierr);
    if (!ierr) G.model_remove(&ierr);
    clear_new_names(s);
    if (s->onelab_before) {       /* the caller's ONELAB database as it was */
        onelab_empty(s);
        ierr = 0;
        G.onelab_set(s->onelab_before, "json", &ierr);
        G.free(s->onelab_before);
    }
    for (j = 0; j < s->n_names_before; j++) G.free(s->names_before[j]);
    if (s->names_before) G.free(s->names_before);
    G.option_set_number("General.Terminal", s->terminal, &ierr);
    G.option_set_number("Mesh.MeshSizeMax", s->size_max, &ierr);
    if (s->previous_model) {
        G.model_set_current(s->previous_model, &ierr);
        G.free(s->previous_model);
    }
}

static int cmp_size(const void *a, const void *b)
{
    size_t x = *(const size_t *)a, y = *(const size_t *)b;
    return (x > y) - (x < y);
}

/* qsort order of (group, node) pairs stored as two consecutive ints. */
static int cmp_pair(const void *a, const void *b)
{
    const int *x = a, *y = b;
    if (x[0] != y[0]) return x[0] < y[0] ? -1 : 1;
    return (x[1] > y[1]) - (x[1] < y[1]);
}

/* Index (1-based) of tag in sorted[0..n), 0 if absent. */
static int find_tag(const size_t *sorted, size_t n, size_t tag)
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (sorted[mid] < tag) lo = mid + 1; else hi = mid;
    }
    return (lo < n && sorted[lo] == tag) ? (int)lo + 1 : 0;
}

/* gmsh element type of the linear simplex of dimension d (point, segment, triangle, tet). */
static int simplex_type(int d) { static const int t[4] = {15, 1, 2, 4}; return t[d]; }

/* The linear simplices of dimension d, as element_name names them. */
static const char *dim_noun(int d)
{
    static const char *n[4] = {"points", "2-node segments", "3-node triangles",
                               "4-node tetrahedra"};
    return n[d];
}

/* gmsh's name of an element type ("6-node triangle"), as its file format's documentation
 * gives it, so that a refusal names what the file holds; "" for a type not listed. */
static const char *element_name(int type)
{
    static const char *names[32] = {
        "", "2-node segment", "3-node triangle", "4-node quadrangle", "4-node tetrahedron",
        "8-node hexahedron", "6-node prism", "5-node pyramid", "3-node segment",
        "6-node triangle", "9-node quadrangle", "10-node tetrahedron", "27-node hexahedron",
        "18-node prism", "14-node pyramid", "1-node point", "8-node quadrangle",
        "20-node hexahedron", "15-node prism", "13-node pyramid", "9-node triangle",
        "10-node triangle", "12-node triangle", "15-node triangle", "15-node triangle",
        "21-node triangle", "4-node segment", "5-node segment", "6-node segment",
        "20-node tetrahedron", "35-node tetrahedron", "56-node tetrahedron"};
    return (type >= 1 && type <= 31) ? names[type] : "";
}

/* What to change in the .geo for an element type that is not a linear simplex: "" if
 * none is known. gmsh's types: higher-order segments, triangles and tetrahedra (8, 9, 11,
 * 20-31), quadrangles, hexahedra, prisms and pyramids of any order (3, 5-7, 10, 12-14,
 * 16-19). */
static const char *element_hint(int type)
{
    static const int higher[] = {8, 9, 11, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29, 30, 31};
    static const int recombined[] = {3, 5, 6, 7, 10, 12, 13, 14, 16, 17, 18, 19};
    size_t i;
    for (i = 0; i < sizeof higher / sizeof *higher; i++)
        if (type == higher[i])
            return " (a higher-order element: mesh with Mesh.ElementOrder = 1)";
    for (i = 0; i < sizeof recombined / sizeof *recombined; i++)
        if (type == recombined[i])
            return " (quadrangles, hexahedra, prisms or pyramids: mesh without Recombine)";
    return "";
}

/* Elements of entity (d, tag): the P1 simplices (tags, nodes) or an error for others. */
typedef struct { size_t n; size_t *tags; size_t *nodes; } block_t;

static int entity_elements(int d, int tag, block_t *b, const char *path, char *msg, int msglen)
{
    int *types = NULL, ierr = 0, st = 0;
    size_t n_types = 0, **etags = NULL, *etags_n = NULL, etags_nn = 0;
    size_t **ntags = NULL, *ntags_n = NULL, ntags_nn = 0, i;
    memset(b, 0, sizeof *b);
    G.get_elements(&types, &n_types, &etags, &etags_n, &etags_nn, &ntags, &ntags_n, &ntags_nn,
                   d, tag, &ierr);
    if (ierr) { gmsh_error(path, "reading the elements", msg, msglen); return 2; }
    for (i = 0; i < n_types; i++) {
        if (types[i] == simplex_type(d) && !b->tags) {
            b->n = etags_n[i];
            b->tags = etags[i];
            b->nodes = ntags[i];
            etags[i] = ntags[i] = NULL;
        } else if (etags_n[i] > 0 && st == 0) {
            char buf[300];
            const char *name = element_name(types[i]);
            snprintf(buf, sizeof buf, ": element type %d (%s%s%sdimension %d) is not a linear "
                     "simplex; only %s are supported in dimension %d%s", types[i],
                     *name ? "a " : "", name, *name ? ", " : "", d, dim_noun(d), d,
                     element_hint(types[i]));
            set_msg(msg, msglen, path, buf, NULL);
            st = 2;
        }
    }
    for (i = 0; i < n_types; i++) {
        if (etags[i]) G.free(etags[i]);
        if (ntags[i]) G.free(ntags[i]);
    }
    G.free(types); G.free(etags); G.free(etags_n); G.free(ntags); G.free(ntags_n);
    if (st) { if (b->tags) G.free(b->tags); if (b->nodes) G.free(b->nodes); memset(b, 0, sizeof *b); }
    return st;
}

/* Physical tags of entity (d, tag) (gmsh-allocated, may be NULL). */
static int *entity_physicals(int d, int tag, size_t *n)
{
    int *p = NULL, ierr = 0;
    *n = 0;
    G.get_physical_groups_for_entity(d, tag, &p, n, &ierr);
    if (ierr) *n = 0;
    return p;
}

typedef struct { int dim, tag; } group_key_t;

/* The g-th (1-based) name of the newline-terminated list `names`, into out. */
static void nth_name(const char *names, int g, char *out, size_t len)
{
    const char *a = names, *b;
    out[0] = '\0';
    for (int k = 1; k < g && a; k++) {
        a = strchr(a, '\n');
        if (a) a++;
    }
    if (!a || !(b = strchr(a, '\n'))) return;
    snprintf(out, len, "%.*s", (int)(b - a), a);
}

/* m->lower_nodes, m->lower_group: the nodes (1-based, numbered in `sorted`) of the
 * elements of dimension below dim - 1 of the entities with physical groups, once per
 * (group, node), sorted by group then node. 0, else 2 (a node unknown) or 4 (memory). */
static int lower_pairs(const char *path, int dim, const size_t *n_ents, int *const *ents,
                       block_t *const *blocks, const group_key_t *groups, int n_groups,
                       const size_t *sorted, size_t n_node_tags, dc_gmsh_mesh_t *m,
                       char *msg, int msglen)
{
    size_t n = 0, e, i, k, v, u;
    int *pairs = NULL;
    for (int pass = 0; pass < 2; pass++) {
        for (int dd = 0; dd < dim - 1; dd++)
            for (e = 0; e < n_ents[dd]; e++) {
                const block_t *b = &blocks[dd][e];
                size_t np;
                int *p = entity_physicals(dd, ents[dd][2 * e + 1], &np);
                for (k = 0; k < np; k++) {
                    int g = 0;
                    for (int j = 0; j < n_groups && !g; j++)
                        if (groups[j].dim == dd && groups[j].tag == p[k]) g = j + 1;
                    for (i = 0; i < b->n * (size_t)(dd + 1); i++, n++) {
                        int idx;
                        if (pass == 0) continue;
                        idx = find_tag(sorted, n_node_tags, b->nodes[i]);
                        if (!idx) {
                            char buf[160];
                            snprintf(buf, sizeof buf, ": element %zu refers to unknown node "
                                     "%zu", b->tags[i / (size_t)(dd + 1)], b->nodes[i]);
                            set_msg(msg, msglen, path, buf, NULL);
                            if (p) G.free(p);
                            free(pairs);
                            return 2;
                        }
                        pairs[2 * n] = g;
                        pairs[2 * n + 1] = idx;
                    }
                }
                if (p) G.free(p);
            }
        if (pass == 0) {
            pairs = malloc((2 * n + 2) * sizeof *pairs);
            if (!pairs) return 4;
            n = 0;
        }
    }
    qsort(pairs, n, 2 * sizeof *pairs, cmp_pair);
    m->lower_nodes = malloc((n + 1) * sizeof(int));
    m->lower_group = malloc((n + 1) * sizeof(int));
    if (!m->lower_nodes || !m->lower_group) { free(pairs); return 4; }
    for (v = 0, u = 0; v < n; v++) {
        if (u > 0 && m->lower_group[u - 1] == pairs[2 * v]
            && m->lower_nodes[u - 1] == pairs[2 * v + 1]) continue;
        m->lower_group[u] = pairs[2 * v];
        m->lower_nodes[u++] = pairs[2 * v + 1];
    }
    m->n_lower = u;
    free(pairs);
    return 0;
}

/* Build the mesh from the current model. keep_untagged: keep cells of entities without a
 * physical group when the model has some (a file: gmsh saved them; a .geo: gmsh would not). */
static int extract(const char *path, int keep_untagged, dc_gmsh_mesh_t *m, char *msg, int msglen)
{
    int ierr = 0, st = 0, d, dim = 0;
    size_t i, k, e, v;
    int *all_groups = NULL;
    size_t n_all_groups = 0;
    group_key_t *groups = NULL;
    int n_groups = 0;
    char *names = NULL;
    size_t names_len = 0;
    size_t *node_tags = NULL, n_node_tags = 0, *sorted = NULL;
    double *coord = NULL, *param = NULL;
    size_t n_coord = 0, n_param = 0;
    int *ents[4] = {0};
    size_t n_ents[4] = {0};
    block_t *blocks[4] = {0};

    /* groups: named by (dim, tag), then unnamed by first use */
    G.get_physical_groups(&all_groups, &n_all_groups, -1, &ierr);
    n_all_groups /= 2;
    groups = calloc(n_all_groups + 1, sizeof *groups);
    if (!groups) return 4;
    for (int pass = 0; pass < 2; pass++) {
        for (d = 0; d <= 3 && pass == 0; d++) {
            for (i = 0; i < n_all_groups; i++) {
                char *name = NULL;
                if (all_groups[2 * i] != d) continue;
                G.get_physical_name(d, all_groups[2 * i + 1], &name, &ierr);
                if (name && *name) {
                    size_t l = strlen(name);
                    names = realloc(names, names_len + l + 2);
                    memcpy(names + names_len, name, l);
                    names[names_len + l] = '\n';
                    names_len += l + 1;
                    groups[n_groups].dim = d;
                    groups[n_groups++].tag = all_groups[2 * i + 1];
                }
                if (name) G.free(name);
            }
        }
        if (pass == 1) {
            /* unnamed groups in order of first use by an entity (by dimension, tag) */
            for (d = 0; d <= 3; d++) {
                int *dt = NULL;
                size_t n = 0;
                G.get_entities(&dt, &n, d, &ierr);
                for (e = 0; e < n / 2; e++) {
                    size_t np;
                    int *p = entity_physicals(d, dt[2 * e + 1], &np);
                    for (k = 0; k < np; k++) {
                        int g, found = 0;
                        for (g = 0; g < n_groups && !found; g++)
                            found = groups[g].dim == d && groups[g].tag == p[k];
                        if (!found) {
                            char buf[16];
                            int l = snprintf(buf, sizeof buf, "%d\n", p[k]);
                            names = realloc(names, names_len + (size_t)l + 1);
                            memcpy(names + names_len, buf, (size_t)l);
                            names_len += (size_t)l;
                            groups[n_groups].dim = d;
                            groups[n_groups++].tag = p[k];
                        }
                    }
                    if (p) G.free(p);
                }
                if (dt) G.free(dt);
            }
        }
    }
    if (all_groups) G.free(all_groups);
    names = realloc(names, names_len + 1);
    names[names_len] = '\0';

    /* entities and their simplices, dimension by dimension */
    for (d = 0; d <= 3 && st == 0; d++) {
        G.get_entities(&ents[d], &n_ents[d], d, &ierr);
        n_ents[d] /= 2;
        blocks[d] = calloc(n_ents[d] + 1, sizeof(block_t));
        for (e = 0; e < n_ents[d] && st == 0; e++)
            st = entity_elements(d, ents[d][2 * e + 1], &blocks[d][e], path, msg, msglen);
    }
    for (d = 1; d <= 3 && st == 0; d++)
        for (e = 0; e < n_ents[d]; e++)
            if (blocks[d][e].n > 0) {
                size_t np;
                int *p = entity_physicals(d, ents[d][2 * e + 1], &np);
                if (p) G.free(p);
                if (keep_untagged || np > 0 || n_groups == 0) dim = d;
            }
    if (st == 0 && dim == 0) {
        set_msg(msg, msglen, path, ": no segments, triangles or tetrahedra in the mesh", NULL);
        st = 2;
    }
    /* an entity of a physical group of the cells' dimension or above that has no elements:
     * gmsh did not mesh it (a .geo surface or volume it cannot mesh), or the file was saved
     * at a lower dimension; taken as it is, the mesh would be the rest (the curves of a
     * surface that failed: a 1D bar where a 2D body was meant) */
    for (d = dim; d <= 3 && st == 0 && dim > 0; d++)
        for (e = 0; e < n_ents[d] && st == 0; e++) {
            size_t np;
            int *p;
            char gname[80], buf[720];
            if (blocks[d][e].n > 0) continue;
            p = entity_physicals(d, ents[d][2 * e + 1], &np);
            if (np > 0) {
                gname[0] = '\0';
                for (int g = 0; g < n_groups; g++)
                    if (groups[g].dim == d && groups[g].tag == p[0])
                        nth_name(names, g + 1, gname, sizeof gname);
                dc_unmeshed_text(d, ents[d][2 * e + 1], gname, dim, keep_untagged, buf,
                                 (int)sizeof buf);
                set_msg(msg, msglen, path, ": ", buf);
                st = 2;
            }
            if (p) G.free(p);
        }

    /* nodes by increasing tag */
    if (st == 0) {
        G.get_nodes(&node_tags, &n_node_tags, &coord, &n_coord, &param, &n_param, -1, -1, 0, 0,
                    &ierr);
        if (ierr) { gmsh_error(path, "reading the nodes", msg, msglen); st = 2; }
    }
    if (st == 0) {
        sorted = malloc((n_node_tags + 1) * sizeof *sorted);
        if (!sorted) st = 4;
    }
    if (st == 0) {
        for (i = 0; i < n_node_tags; i++) sorted[i] = node_tags[i];
        qsort(sorted, n_node_tags, sizeof *sorted, cmp_size);
        for (i = 1; i < n_node_tags; i++)
            if (sorted[i] == sorted[i - 1]) {
                char buf[120];
                snprintf(buf, sizeof buf, ": node tag %zu appears twice", sorted[i]);
                set_msg(msg, msglen, path, buf, NULL);
                st = 2;
                break;
            }
    }

    /* cells and facets */
    if (st == 0) {
        int *used = NULL;
        size_t nc = 0, nf = 0, c = 0, f = 0, nn = 0;
        for (int pass = 0; pass < 2 && st == 0; pass++) {
            for (int dd = dim; dd >= dim - 1 && dd >= 0 && st == 0; dd--) {
                for (e = 0; e < n_ents[dd] && st == 0; e++) {
                    block_t *b = &blocks[dd][e];
                    size_t np;
                    int *p = entity_physicals(dd, ents[dd][2 * e + 1], &np);
                    int gidx[64];
                    size_t ng = np < 64 ? np : 64;
                    for (k = 0; k < ng; k++) {
                        gidx[k] = 0;
                        for (int g = 0; g < n_groups && !gidx[k]; g++)
                            if (groups[g].dim == dd && groups[g].tag == p[k]) gidx[k] = g + 1;
                    }
                    if (p) G.free(p);
                    if (dd == dim) {
                        if (!keep_untagged && np == 0 && n_groups > 0) continue;
                        if (pass == 0) { nc += b->n; continue; }
                        for (i = 0; i < b->n && st == 0; i++, c++) {
                            for (v = 0; v < (size_t)dim + 1; v++) {
                                int idx = find_tag(sorted, n_node_tags, b->nodes[i * (dim + 1) + v]);
                                if (!idx) {
                                    char buf[160];
                                    snprintf(buf, sizeof buf, ": element %zu refers to unknown "
                                             "node %zu", b->tags[i], b->nodes[i * (dim + 1) + v]);
                                    set_msg(msg, msglen, path, buf, NULL);
                                    st = 2;
                                    break;
                                }
                                m->cells[c * (dim + 1) + v] = idx;
                                if (used) used[idx - 1] = 1;
                            }
                            m->cell_group[c] = ng > 0 ? gidx[0] : 0;
                        }
                    } else {
                        if (pass == 0) { nf += b->n * ng; continue; }
                        for (i = 0; i < b->n && st == 0; i++)
                            for (k = 0; k < ng && st == 0; k++, f++) {
                                for (v = 0; v < (size_t)dim; v++) {
                                    int idx = find_tag(sorted, n_node_tags, b->nodes[i * dim + v]);
                                    if (!idx) {
                                        char buf[160];
                                        snprintf(buf, sizeof buf, ": element %zu refers to "
                                                 "unknown node %zu", b->tags[i],
                                                 b->nodes[i * dim + v]);
                                        set_msg(msg, msglen, path, buf, NULL);
                                        st = 2;
                                        break;
                                    }
                                    m->facets[f * dim + v] = idx;
                                }
                                m->facet_group[f] = gidx[k];
                            }
                    }
                }
            }
            if (pass == 0) {
                m->dim = dim;
                m->n_cells = nc;
                m->n_facets = nf;
                m->cells = malloc((nc * (dim + 1) + 1) * sizeof(int));
                m->cell_group = malloc((nc + 1) * sizeof(int));
                m->facets = malloc((nf * dim + 1) * sizeof(int));
                m->facet_group = malloc((nf + 1) * sizeof(int));
                if (!keep_untagged) used = calloc(n_node_tags + 1, sizeof(int));
                if (!m->cells || !m->cell_group || !m->facets || !m->facet_group)
                    st = 4;
            }
        }
        /* lower nodes: (group, node) pairs of the groups below dimension dim - 1 */
        if (st == 0) st = lower_pairs(path, dim, n_ents, ents, blocks, groups, n_groups,
                                      sorted, n_node_tags, m, msg, msglen);
        /* nodes: all of them (a file), or those of the kept cells (a .geo) */
        if (st == 0) {
            size_t *pos = malloc((n_node_tags + 1) * sizeof *pos);   /* tag position */
            int *renum = malloc((n_node_tags + 1) * sizeof *renum);
            for (i = 0; i < n_node_tags; i++)
                pos[find_tag(sorted, n_node_tags, node_tags[i]) - 1] = i;
            for (i = 0; i < n_node_tags; i++)
                renum[i] = (!used || used[i]) ? (int)++nn : 0;
            m->n_nodes = nn;
            m->xyz = malloc((3 * nn + 1) * sizeof(double));
            for (i = 0; i < n_node_tags; i++)
                if (renum[i])
                    memcpy(m->xyz + 3 * (renum[i] - 1), coord + 3 * pos[i], 3 * sizeof(double));
            if (used) {
                for (i = 0; i < m->n_cells * (dim + 1); i++) m->cells[i] = renum[m->cells[i] - 1];
                for (i = 0; i < m->n_facets * dim; i++)
                    m->facets[i] = renum[m->facets[i] - 1];
                for (i = 0; i < m->n_lower && st == 0; i++) {
                    if (!renum[m->lower_nodes[i] - 1]) {
                        char gname[80], buf[240];
                        nth_name(names, m->lower_group[i], gname, sizeof gname);
                        snprintf(buf, sizeof buf, ": physical group '%s' has a node in no "
                                 "cell (the cells are the %s)", gname, dim_noun(dim));
                        set_msg(msg, msglen, path, buf, NULL);
                        st = 2;
                    }
                    m->lower_nodes[i] = renum[m->lower_nodes[i] - 1];
                }
            }
            free(pos);
            free(renum);
        }
        free(used);
    }

    m->n_groups = n_groups;
    m->group_dim = malloc(((size_t)n_groups + 1) * sizeof(int));
    for (int g = 0; g < n_groups; g++) m->group_dim[g] = groups[g].dim;
    m->group_names = names;
    free(groups);
    free(sorted);
    if (node_tags) G.free(node_tags);
    if (coord) G.free(coord);
    if (param) G.free(param);
    for (d = 0; d <= 3; d++) {
        for (e = 0; blocks[d] && e < n_ents[d]; e++) {
            if (blocks[d][e].tags) G.free(blocks[d][e].tags);
            if (blocks[d][e].nodes) G.free(blocks[d][e].nodes);
        }
        free(blocks[d]);
        if (ents[d]) G.free(ents[d]);
    }
    return st;
}

void dc_gmsh_free(void *p);

/* The element count of a .geo estimated before meshing (docs/scenes.md, "How large a .geo
 * will be"): the measure of the cells' entities (volume in 3D, area in 2D, length in 1D)
 * over the measure a cell of the target size s takes in gmsh's unstructured meshes,
 * calibrated on gmsh 4.15's own meshes of boxes, cylinders, balls, disks and rectangles:
 *   3D: n = 4.67 V / s^3   (0.55 x the count of regular tetrahedra of edge s, V 6 sqrt 2/s^3)
 *   2D: n = 2.31 A / s^2   (the count of equilateral triangles of edge s, A 4/sqrt 3/s^2)
 *   1D: n = L / s.
 * The measure: OpenCASCADE's (occ.getMass) for every entity the OCC kernel built; for a
 * plane surface of the built-in kernel the area enclosed by its oriented boundary curves,
 * each sampled at ESTIMATE_SAMPLES points (the vector area, exact for straight lines), and
 * for a volume of the built-in kernel bounded by plane surfaces the volume those enclose
 * (the divergence theorem on their vector areas).
 * With physical groups of the mesh's dimension, only the entities in a group (the cells
 * kept). The size: the largest size of the points (Mesh.MeshSizeFromPoints, where
 * Mesh.MeshSizeExtendFromBoundary carries them into the cells' interior), bounded by
 * Mesh.MeshSizeMax (the scene's h where the file uses no h) and Mesh.MeshSizeMin, times
 * Mesh.MeshSizeFactor: sizes from curvature or fields only make cells smaller, so the
 * estimate is then too low, never too high. No estimate (est[0] = -1) when a measure is
 * not known (a volume of the built-in kernel with a face that is not plane, a gmsh
 * without these functions) or no size
 * is (no point size, no Mesh.MeshSizeMax), and for a .geo with transfinite or extruded
 * meshes (their counts are set by the file, not by the sizes), which the caller then
 * meshes and counts.
 * est = (estimate, measure, size, ESTIMATE_MARGIN). */
#define ESTIMATE_SAMPLES 257
/* A .geo is refused before meshing when its estimate exceeds ESTIMATE_MARGIN x the limit:
 * the measured counts were 0.96 to 2.2 x the estimate (docs/scenes.md). */
#define ESTIMATE_MARGIN 2.0

/* est = "no estimate" (-1, no measure, no size) with the refusal's margin. */
static void no_estimate(double est[4])
{
    est[0] = -1; est[1] = 0; est[2] = 0; est[3] = ESTIMATE_MARGIN;
}

/* 1 when gmsh's library is loaded (loading it if need be), else 0 with
 * "path: <why gmsh is not available>" in msg. */
static int gmsh_loaded(const char *path, char *msg, int msglen)
{
    char buf[1024];
    if (gmsh_load()) return 1;
    dc_gmsh_available(msg, msglen);
    snprintf(buf, sizeof buf, "%s: %s", path, msg);
    set_msg(msg, msglen, buf, NULL, NULL);
    return 0;
}

/* Whether the file's text holds one of the words that fix counts of cells (Transfinite,
 * Extrude, Layers) or reads other files (Include, Merge), which the estimate cannot see. */
static int geo_fixes_counts(const char *path)
{
    static const char *words[] = {"transfinite", "extrude", "layers", "include", "merge"};
    FILE *f = fopen(path, "r");
    char line[4096];
    int found = 0;
    size_t w;
    if (!f) return 1;
    while (!found && fgets(line, sizeof line, f))
        for (w = 0; w < sizeof words / sizeof *words && !found; w++)
            found = strcasestr(line, words[w]) != NULL;
    fclose(f);
    return found;
}

/* The vector area of the surface tag of the built-in kernel (half the vector sum of
 * p_i x p_{i+1} along its oriented boundary curves: its area times its unit normal for a
 * plane surface) into va, and a point of its boundary into p0; 0, or -1 if unknown. */
static int vector_area(int tag, double va[3], double p0[3])
{
    int dt[2] = {2, tag}, *bd = NULL, ierr = 0;
    size_t nb = 0, k, i;
    double u[ESTIMATE_SAMPLES];
    va[0] = va[1] = va[2] = 0;
    G.get_boundary(dt, 2, &bd, &nb, 0, 1, 0, &ierr);
    if (ierr || nb == 0) { if (bd) G.free(bd); return -1; }
    for (k = 0; k + 1 < nb && ierr == 0; k += 2) {
        int c = bd[k + 1] < 0 ? -bd[k + 1] : bd[k + 1];
        double *lo = NULL, *hi = NULL, *x = NULL;
        size_t nlo = 0, nhi = 0, nx = 0;
        G.get_parametrization_bounds(1, c, &lo, &nlo, &hi, &nhi, &ierr);
        if (!ierr && nlo == 1 && nhi == 1) {
            for (i = 0; i < ESTIMATE_SAMPLES; i++)
                u[i] = lo[0] + (hi[0] - lo[0]) * (double)i / (ESTIMATE_SAMPLES - 1);
            G.get_value(1, c, u, ESTIMATE_SAMPLES, &x, &nx, &ierr);
        }
        if (!ierr && nx == 3 * ESTIMATE_SAMPLES) {
            double sgn = bd[k + 1] < 0 ? -0.5 : 0.5;
            if (k == 0) memcpy(p0, x, 3 * sizeof(double));
            for (i = 0; i + 1 < ESTIMATE_SAMPLES; i++) {
                const double *a = x + 3 * i, *b = x + 3 * (i + 1);
                va[0] += sgn * (a[1] * b[2] - a[2] * b[1]);
                va[1] += sgn * (a[2] * b[0] - a[0] * b[2]);
                va[2] += sgn * (a[0] * b[1] - a[1] * b[0]);
            }
        } else {
            ierr = 1;
        }
        if (lo) G.free(lo);
        if (hi) G.free(hi);
        if (x) G.free(x);
    }
    G.free(bd);
    return ierr ? -1 : 0;
}

/* Area of the plane surface tag of the built-in kernel; -1 if unknown. */
static double surface_area(int tag)
{
    double va[3], p0[3];
    if (vector_area(tag, va, p0)) return -1;
    return sqrt(va[0] * va[0] + va[1] * va[1] + va[2] * va[2]);
}

/* Volume of the volume tag of the built-in kernel bounded by plane surfaces (the
 * divergence theorem: a third of the sum over its oriented faces of p0 . va); -1 if
 * unknown (a face that is not plane). */
static double volume_of_planes(int tag)
{
    int dt[2] = {3, tag}, *bd = NULL, ierr = 0;
    size_t nb = 0, k;
    double v = 0;
    G.get_boundary(dt, 2, &bd, &nb, 0, 1, 0, &ierr);
    if (ierr || nb == 0) { if (bd) G.free(bd); return -1; }
    for (k = 0; k + 1 < nb && ierr == 0; k += 2) {
        int f = bd[k + 1] < 0 ? -bd[k + 1] : bd[k + 1];
        char *type = NULL;
        double va[3], p0[3];
        G.get_type(2, f, &type, &ierr);
        if (ierr || !type || strcmp(type, "Plane") != 0 || vector_area(f, va, p0))
            ierr = 1;
        else
            v += (bd[k + 1] < 0 ? -1.0 : 1.0) * (p0[0] * va[0] + p0[1] * va[1] + p0[2] * va[2]);
        if (type) G.free(type);
    }
    G.free(bd);
    return ierr ? -1 : fabs(v) / 3;
}

/* The estimate of the current model, a .geo read from path (see above). */
static void geo_estimate(const char *path, double est[4])
{
    int ierr = 0, d, *ents = NULL, *groups = NULL;
    size_t n_ents = 0, n_groups = 0, e, g;
    double measure = 0, size = HUGE_VAL, smax = 1e22, smin = 0, factor = 1, from_points = 1,
           extend = 1;
    no_estimate(est);
    if (!G.occ_get_mass || !G.get_boundary || !G.get_parametrization_bounds || !G.get_value
        || !G.get_sizes || !G.get_entities_for_physical_group || !G.get_type
        || geo_fixes_counts(path))
        return;
    d = G.get_dimension(&ierr);
    if (ierr || d < 1 || d > 3) return;
    G.get_entities(&ents, &n_ents, d, &ierr);
    G.get_physical_groups(&groups, &n_groups, d, &ierr);
    n_ents /= 2;
    n_groups /= 2;
    for (e = 0; e < n_ents && measure >= 0; e++) {
        int tag = ents[2 * e + 1], kept = n_groups == 0;
        double m = -1;
        for (g = 0; g < n_groups && !kept; g++) {
            int *tags = NULL;
            size_t nt = 0, t;
            G.get_entities_for_physical_group(d, groups[2 * g + 1], &tags, &nt, &ierr);
            for (t = 0; t < nt && !kept; t++) kept = tags[t] == tag;
            if (tags) G.free(tags);
        }
        if (!kept) continue;
        ierr = 0;
        G.occ_get_mass(d, tag, &m, &ierr);
        if (ierr) m = d == 2 ? surface_area(tag) : d == 3 ? volume_of_planes(tag) : -1;
        measure = m >= 0 ? measure + m : -1;
    }
    if (ents) G.free(ents);
    if (groups) G.free(groups);
    if (measure < 0) return;

    ierr = 0;
    G.option_get_number("Mesh.MeshSizeFromPoints", &from_points, &ierr);
    G.option_get_number("Mesh.MeshSizeMax", &smax, &ierr);
    G.option_get_number("Mesh.MeshSizeMin", &smin, &ierr);
    G.option_get_number("Mesh.MeshSizeFactor", &factor, &ierr);
    G.option_get_number("Mesh.MeshSizeExtendFromBoundary", &extend, &ierr);
    /* the points' sizes reach the cells' interior only where they are extended from the
     * boundary into it (1, 2: surfaces and volumes; -2: surfaces; -3: volumes) */
    if (d >= 2 && !(extend == 1 || extend == 2 || extend == (d == 2 ? -2 : -3)))
        from_points = 0;
    if (from_points != 0) {
        int *pts = NULL;
        size_t np = 0;
        double *sz = NULL;
        size_t ns = 0, i, k = 0;
        G.get_entities(&pts, &np, 0, &ierr);
        if (!ierr && np > 0) G.get_sizes(pts, np, &sz, &ns, &ierr);
        for (i = 0; !ierr && i < ns; i++)
            if (sz[i] > 0 && sz[i] < 1e22) { size = k++ ? fmax(size, sz[i]) : sz[i]; }
        if (pts) G.free(pts);
        if (sz) G.free(sz);
    }
    if (smax > 0 && smax < size) size = smax;
    if (smin > size) size = smin;
    size *= factor;
    if (!(size > 0 && size < 1e22)) return;
    est[1] = measure;
    est[2] = size;
    est[0] = d == 3 ? 0.55 * 6 * sqrt(2.0) * measure / (size * size * size)
           : d == 2 ? 4 / sqrt(3.0) * measure / (size * size) : measure / size;
}

/* The bits of params[3], `given`: the parameters (PARAM_NAMES) the scene gives. */
#define GIVEN_H 1
#define GIVEN_LENGTH 2
#define GIVEN_WIDTH 4

/* Set the .geo parameters of the bits of `set` to params, and clear the others. */
static void set_parameters(const double *params, int set)
{
    int ierr = 0, i;
    for (i = 0; i < 3; i++) {
        if (set & (1 << i)) G.parser_set_number(PARAM_NAMES[i], &params[i], 1, &ierr);
        else G.parser_clear(PARAM_NAMES[i], &ierr);
    }
}

/* Parse the .geo path once into the current model with the parameters of the bits of
 * `set` set to params and the others cleared, to see how it uses them: 1 if the parse
 * has an error, 0 if not; *defined gets the bits of the parameters that are parser
 * variables after it (those of `set`, and those the file defines, DefineConstant).
 * The parse runs to the end of the file whatever its errors (AbortOnError 0): a parse
 * stopped at its first error (gmsh's default in the API, an exception) leaves the rest
 * of the file in gmsh's lexer, which the next parse reads first (a .geo using h without
 * defining it then failed with "line 0: syntax error"); a variable it uses undefined is
 * an error after which the parse goes on, so the file's later definitions are seen. An
 * error is seen as gmsh's last error replacing PROBE_MARK, written first. The model, the
 * variables and the ONELAB parameters of the parse are removed after it. */
static int geo_probe(const char *path, const double *params, int set, int *defined,
                     session_t *s)
{
    static const char PROBE_MARK[] = "dyncontact: parsing the .geo without h";
    int ierr = 0, err, i;
    char **names = NULL;
    char *last = NULL;
    size_t n = 0, j;
    double abort_on_error = 2;
    set_parameters(params, set);
    G.option_get_number("General.AbortOnError", &abort_on_error, &ierr);
    G.option_set_number("General.AbortOnError", 0, &ierr);
    G.logger_write(PROBE_MARK, "error", &ierr);
    ierr = 0;
    G.merge(path, &ierr);
    if (!ierr) {
        G.last_error(&last, &ierr);
        if (ierr || !last || strcmp(last, PROBE_MARK) != 0) ierr = 1;
        if (last) G.free(last);
    }
    err = ierr != 0;
    ierr = 0;
    G.option_set_number("General.AbortOnError", abort_on_error, &ierr);
    *defined = 0;
    G.parser_get_names(&names, &n, "", &ierr);
    for (j = 0; j < n; j++) {
        for (i = 0; i < 3; i++)
            if (strcmp(names[j], PARAM_NAMES[i]) == 0) *defined |= 1 << i;
        G.free(names[j]);
    }
    if (names) G.free(names);
    G.model_remove(&ierr);
    G.model_add(MODEL, &ierr);
    clear_new_names(s);          /* the variables of that parse */
    onelab_empty(s);             /* and its ONELAB parameters */
    return err;
}

/* Parse the .geo path into the current model with its parameters (h, length, width) =
 * params[0..2] set where the scene gives them (the bits of params[3], GIVEN_*), as
 * gmsh -setnumber would: a file that defines one (DefineConstant[h = {...}]) keeps its
 * own value where the scene does not give it, as gmsh without -setnumber meshes it; one
 * that uses it without defining it gets params' value (the scene's default). Where the
 * file uses no h and the scene gives h, h is its largest mesh size. */
static int geo_parse(const char *path, const double *params, session_t *s, char *msg,
                     int msglen)
{
    const int given = (int)params[3];
    int uses_h, needs_h, err, defined = 0, set, ierr = 0;
    /* length and width not given: set unless the file defines them (seen in a parse
     * without them and without h, which an undefined variable does not stop) */
    err = geo_probe(path, params, given & (GIVEN_LENGTH | GIVEN_WIDTH), &defined, s);
    set = (given | ~defined) & (GIVEN_LENGTH | GIVEN_WIDTH);
    /* does the file use h? parsed without h (length and width as set): it then
     * defines h, or fails */
    if (err && set != (given & (GIVEN_LENGTH | GIVEN_WIDTH)))
        err = geo_probe(path, params, set, &defined, s);
    needs_h = err;
    uses_h = err || (defined & GIVEN_H);
    if ((given & GIVEN_H) || needs_h) set |= GIVEN_H;
    set_parameters(params, set);
    ierr = 0;
    G.merge(path, &ierr);
    if (ierr) { gmsh_error(path, "gmsh cannot read it", msg, msglen); return 2; }
    if (!uses_h && (given & GIVEN_H))
        G.option_set_number("Mesh.MeshSizeMax", params[0], &ierr);
    return 0;
}

/* Read path into *out (free with dc_gmsh_free). params = (h, length, width, given,
 * max_elements) for a .geo: the first three are set as the file's parser variables of
 * those names where `given` (bits GIVEN_H, GIVEN_LENGTH, GIVEN_WIDTH: the scene gives
 * them) or the file uses them without defining them (geo_parse); if the file uses no h
 * and the scene gives &mesh h, h is the largest mesh size (Mesh.MeshSizeMax); a file
 * that uses no h, meshed for a scene that gives no h, keeps its own sizes (a default h
 * made for the built-in bar, 0.05, imposed on a body drawn in mm would mesh it with
 * billions of elements). max_elements > 0: a .geo whose
 * estimated element count (geo_estimate, into est) exceeds ESTIMATE_MARGIN x max_elements
 * is not meshed: status 5, the estimate in est, no message (the caller names its keys).
 * est[0] = -1 when no estimate was made. */
static int gmsh_read(const char *path, const double *params, int is_geo, void **out,
                     double est[4], char *msg, int msglen, const signal_state_t *sigs);

int dc_gmsh_read(const char *path, const double *params, int is_geo, void **out,
                 double est[4], char *msg, int msglen)
{
    signal_state_t sigs;
    stop_watch_t watch;
    char head[4096];
    int st;
    signals_save(&sigs);
    snprintf(head, sizeof head, "dyncontact: %s: interrupted by signal ", path);
    stop_watch_start(&watch, head, STOP_TAIL);
    st = gmsh_read(path, params, is_geo, out, est, msg, msglen, &sigs);
    stop_watch_end(&watch);
    signals_restore(&sigs);
    return st;
}

/* The estimate of geo_estimate for the .geo path with params (h, length, width, given)
 * as dc_gmsh_read would mesh it, without meshing: status 0 (est[0] = -1: no estimate), 2
 * (bad input, message in msg). */
int dc_gmsh_estimate(const char *path, const double *params, double est[4], char *msg,
                     int msglen)
{
    signal_state_t sigs;
    session_t s;
    int st;
    no_estimate(est);
    signals_save(&sigs);
    if (!gmsh_loaded(path, msg, msglen)) {
        signals_restore(&sigs);
        return 2;
    }
    if (session_begin(&s)) {
        gmsh_error(path, "gmsh initialization", msg, msglen);
        st = 2;
    } else {
        stop_signals_after_init(&sigs);
        st = geo_parse(path, params, &s, msg, msglen);
        if (st == 0) geo_estimate(path, est);
    }
    session_end(&s);
    signals_restore(&sigs);
    return st;
}

/* dc_gmsh_read inside its signal guard (sigs: the dispositions it saved, put back for the
 * stop signals after gmsh's initialization by stop_signals_after_init). */
static int gmsh_read(const char *path, const double *params, int is_geo, void **out,
                     double est[4], char *msg, int msglen, const signal_state_t *sigs)
{
    session_t s;
    int ierr = 0, st = 0;
    dc_gmsh_mesh_t *m;
    *out = NULL;
    no_estimate(est);
    if (!gmsh_loaded(path, msg, msglen)) return 2;
    m = calloc(1, sizeof *m);
    if (!m) return 4;
    if (session_begin(&s)) {
        gmsh_error(path, "gmsh initialization", msg, msglen);
        session_end(&s);
        free(m);
        return 2;
    }
    stop_signals_after_init(sigs);
    if (is_geo) {
        st = geo_parse(path, params, &s, msg, msglen);
        if (st == 0 && params[4] > 0) {
            geo_estimate(path, est);
            if (est[0] > ESTIMATE_MARGIN * params[4]) st = 5;
        }
        if (st == 0) {
            int d = G.get_dimension(&ierr);
            G.mesh_generate(d, &ierr);
            if (ierr) { gmsh_error(path, "gmsh cannot mesh it", msg, msglen); st = 2; }
        }
    } else {
        G.merge(path, &ierr);
        if (ierr) { gmsh_error(path, "gmsh cannot read it", msg, msglen); st = 2; }
    }
    if (st == 0) st = extract(path, !is_geo, m, msg, msglen);
    session_end(&s);
    if (st) { dc_gmsh_free(m); return st; }
    *out = m;
    return 0;
}

#endif

/* Sizes of a mesh read by dc_gmsh_read. */
void dc_gmsh_sizes(void *p, int *dim, long long *n_nodes, long long *n_cells,
                   long long *n_facets, int *n_groups, int *names_len)
{
    dc_gmsh_mesh_t *m = p;
    *dim = m->dim;
    *n_nodes = (long long)m->n_nodes;
    *n_cells = (long long)m->n_cells;
    *n_facets = (long long)m->n_facets;
    *n_groups = m->n_groups;
    *names_len = m->group_names ? (int)strlen(m->group_names) : 0;
}

/* Copy the arrays of a mesh read by dc_gmsh_read (sizes from dc_gmsh_sizes). */
void dc_gmsh_arrays(void *p, double *xyz, int *cells, int *cell_group, int *facets,
                    int *facet_group, int *group_dim, char *names)
{
    dc_gmsh_mesh_t *m = p;
    memcpy(xyz, m->xyz, 3 * m->n_nodes * sizeof(double));
    memcpy(cells, m->cells, (size_t)(m->dim + 1) * m->n_cells * sizeof(int));
    memcpy(cell_group, m->cell_group, m->n_cells * sizeof(int));
    memcpy(facets, m->facets, (size_t)m->dim * m->n_facets * sizeof(int));
    memcpy(facet_group, m->facet_group, m->n_facets * sizeof(int));
    memcpy(group_dim, m->group_dim, (size_t)m->n_groups * sizeof(int));
    if (m->group_names) memcpy(names, m->group_names, strlen(m->group_names));
}

/* Number of (group, node) pairs of the groups below dimension dim - 1 (Physical Points;
 * Curves of a 3D mesh) of a mesh read by dc_gmsh_read. */
void dc_gmsh_lower_size(void *p, long long *n_lower)
{
    dc_gmsh_mesh_t *m = p;
    *n_lower = (long long)m->n_lower;
}

/* Copy those pairs: 1-based node numbers and group indices, sorted by group then node. */
void dc_gmsh_lower_arrays(void *p, int *nodes, int *group)
{
    dc_gmsh_mesh_t *m = p;
    if (m->n_lower == 0) return;
    memcpy(nodes, m->lower_nodes, m->n_lower * sizeof(int));
    memcpy(group, m->lower_group, m->n_lower * sizeof(int));
}

/* Release a mesh of dc_gmsh_read (NULL is fine). */
void dc_gmsh_free(void *p)
{
    dc_gmsh_mesh_t *m = p;
    if (!m) return;
    free(m->xyz); free(m->cells); free(m->cell_group); free(m->facets);
    free(m->facet_group); free(m->group_dim); free(m->group_names);
    free(m->lower_nodes); free(m->lower_group);
    free(m);
}
