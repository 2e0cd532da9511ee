/* run_guard.c: the few POSIX calls the Fortran core needs and Fortran cannot make
 * itself (bound through bind(C) in os_files.f90 and main.f90):
 *   - SIGINT / SIGTERM handlers that only set the stop flag (base/stop_signal.c), read
 *     before each step and in a run's set-up (not for a signal the process ignores from
 *     its start: it stays ignored);
 *   - an output-folder lock file created with O_EXCL that holds the owner's pid (and, on
 *     Linux, the process's start time and the boot id, so that a pid reused after a
 *     kill -9 or a reboot is not taken for the owner);
 *   - whole-buffer writes to a file descriptor (every error reported, EINTR retried),
 *     close, rename, unlink and mkdir with their errno, so that a full disk is never silent;
 *   - the free bytes and file slots of a folder's file system (statvfs), to refuse a run
 *     whose outputs cannot fit before it starts;
 *   - fsync, reopening a file cut back to a given size (a trace continued from a
 *     checkpoint), and a 64-bit FNV-1a hash of a byte buffer (checkpoint checksums);
 *   - the removal of a previous run's snapshots (files of a folder by prefix and suffix),
 *     or of those after a checkpoint's step (numbered names above a number);
 *     and whether two paths name the same folder (device and inode).
 * Every function returns 0 on success and errno (> 0) on failure unless said otherwise. */
#include <dirent.h>
#include <errno.h>
#include <math.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <stdint.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <sys/types.h>
#include <unistd.h>

static volatile sig_atomic_t dc_signals_own = 0;   /* the executable's handlers installed */

static volatile sig_atomic_t dc_read_exit = 0;     /* dc_exit_on_read_signal has run */

void dc_on_stop_signal(int sig);   /* base/stop_signal.c: sets the stop flag */

/* Point signal sig at the action sa, unless the process ignores it: a signal ignored
 * when the program starts (SIG_IGN is inherited through exec: `nohup` ignores SIGHUP, a
 * shell without job control starts its background jobs, `cmd &` in a script, with SIGINT
 * and SIGQUIT ignored) is meant to leave the program alone, and stays ignored, as shells,
 * make and Python leave it (Python installs no KeyboardInterrupt for a SIGINT ignored at
 * its start). 0 or errno. */
static int catch_unless_ignored(int sig, const struct sigaction *sa)
{
    struct sigaction current;
    if (sigaction(sig, NULL, &current) != 0) return errno;
    if (!(current.sa_flags & SA_SIGINFO) && current.sa_handler == SIG_IGN) return 0;
    return sigaction(sig, sa, NULL) == 0 ? 0 : errno;
}

/* Install the SIGINT and SIGTERM handlers (executable only; a signal the process ignores
 * from its start stays ignored: catch_unless_ignored), and ignore SIGXFSZ: a write
 * past the file-size limit (ulimit -f, a batch system's RLIMIT_FSIZE) then fails with
 * EFBIG and is reported as any other failed write (summary status "write_failed", exit
 * 4), as under Python, which ignores SIGXFSZ, instead of killing the process. SIGPIPE is
 * ignored too, as Python does: a reader that closes the pipe of stdout (`| head -1`)
 * then makes the program's own lines fail with EPIPE, which main.f90 disregards, instead
 * of killing the run before or while it writes its files. */
int dc_signals_install(void)
{
    struct sigaction sa;
    int err;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = dc_on_stop_signal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESTART;
    if ((err = catch_unless_ignored(SIGINT, &sa)) != 0) return err;
    if ((err = catch_unless_ignored(SIGTERM, &sa)) != 0) return err;
#ifdef SIGXFSZ
    if (signal(SIGXFSZ, SIG_IGN) == SIG_ERR) return errno;
#endif
    if (signal(SIGPIPE, SIG_IGN) == SIG_ERR) return errno;
    dc_signals_own = 1;
    return 0;
}

/* Called once by a program hosted in another process image (`python -m dyncontact run`
 * and `mesh`): from then on SIGINT / SIGTERM during a gmsh read end the process as in the
 * executable (gmsh_shim.c), with exit status 130 and the same line. A switch of the
 * process, never cleared, like the executable's handlers, and never set by the library:
 * whether a signal may end the process belongs to the program that owns it; a script or
 * notebook that calls the library keeps its own handling of the signals. What the caller
 * wrote before the read that the exit would leave behind (a temporary file) must be
 * named to dc_stop_removes (gmsh_shim.c) first; nothing else may be (an output folder, a
 * lock). */
void dc_exit_on_read_signal(void) { dc_read_exit = 1; }

/* 1 when SIGINT / SIGTERM during a gmsh read may end the process, while nothing has been
 * written (gmsh_shim.c): in the executable (dc_signals_install has run) or a program that
 * called dc_exit_on_read_signal; 0 in a library caller's process (a Python script or
 * notebook), whose own handling of the signals stays. */
int dc_read_signal_exits(void) { return dc_signals_own || dc_read_exit; }

/* Point signal sig (SIGINT or SIGTERM) at the stop flag's handler, for a library caller
 * whose own handler of it is Python code (core.py's _SignalsHeld, over the core's call
 * that opens a run): the run's set-up then sees the signal and stops within a fraction
 * of a second (base/stop_signal.c). The caller puts its own handler back after the call
 * (Python's signal.signal) and takes the flag (dc_stop_signal_take). A signal the process
 * ignores stays ignored. 0 or errno (EINVAL for another signal). */
int dc_stop_signals_catch(int sig)
{
    struct sigaction sa;
    if (sig != SIGINT && sig != SIGTERM) return EINVAL;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = dc_on_stop_signal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESTART;
    return catch_unless_ignored(sig, &sa);
}

/* Open path for writing (created or truncated, mode 0644). Returns fd >= 0 or -errno. */
int dc_fd_open(const char *path)
{
    int fd;
    do {
        fd = open(path, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    } while (fd < 0 && errno == EINTR);
    return fd >= 0 ? fd : -errno;
}

/* Write all n bytes of buf (one write(2) per call unless the kernel takes less). On
 * failure (e.g. ENOSPC after a short write) the file is cut back to the last newline
 * written, so that it never ends with part of a line (a trace keeps whole rows). */
int dc_fd_write(int fd, const char *buf, long n)
{
    long done = 0;
    off_t start = lseek(fd, 0, SEEK_CUR);
    while (done < n) {
        ssize_t w = write(fd, buf + done, (size_t)(n - done));
        int err = 0;
        if (w < 0) {
            if (errno == EINTR) continue;
            err = errno;
        } else if (w == 0) {
            err = ENOSPC;
        }
        if (err != 0) {
            if (start >= 0 && done > 0) {
                long keep = done;
                while (keep > 0 && buf[keep - 1] != '\n') keep--;
                if (ftruncate(fd, start + keep) == 0) lseek(fd, start + keep, SEEK_SET);
            }
            return err;
        }
        done += w;
    }
    return 0;
}

/* Close a descriptor (its error, e.g. a delayed ENOSPC on a network disk, is returned). */
int dc_fd_close(int fd) { return close(fd) == 0 ? 0 : errno; }

/* Create one folder (mode 0755 before the umask): 0 when made or when something of that
 * name is there already (a folder or not: the caller checks what), else errno. */
int dc_mkdir(const char *path) { return mkdir(path, 0755) == 0 || errno == EEXIST ? 0 : errno; }

/* 1 when errno err says the file system has no room or takes no writes (full, over a
 * quota or a file-size limit, read-only), 0 for any other reason (a bad path: a file in
 * the way, no such parent, no permission). The same set as WRITE_ERRNOS in
 * python/dyncontact/cli.py: exit 4 for the first, 2 (bad input) for the others. */
int dc_errno_no_room(int err)
{
    switch (err) {
    case ENOSPC: case EDQUOT: case EFBIG: case EROFS: return 1;
    default: return 0;
    }
}

/* Flush a descriptor's data to the device. */
int dc_fsync(int fd)
{
    int r;
    do { r = fsync(fd); } while (r != 0 && errno == EINTR);
    return r == 0 ? 0 : errno;
}

/* Open an existing file for writing, cut it back to `size` bytes and place the offset
 * at its end. Returns fd >= 0 or -errno. */
int dc_fd_reopen(const char *path, long long size)
{
    int fd;
    do {
        fd = open(path, O_WRONLY | O_CLOEXEC);
    } while (fd < 0 && errno == EINTR);
    if (fd < 0) return -errno;
    if (ftruncate(fd, (off_t)size) != 0 || lseek(fd, (off_t)size, SEEK_SET) < 0) {
        int err = errno;
        close(fd);
        return -err;
    }
    return fd;
}

/* 64-bit FNV-1a hash of n bytes, continuing from h (start with 0: the offset basis is
 * used then). The unsigned result is returned in a signed 64-bit integer. */
long long dc_hash64(const char *buf, long long n, long long h)
{
    uint64_t x = h == 0 ? 14695981039346656037ULL : (uint64_t)h;
    long long i;
    for (i = 0; i < n; i++) {
        x ^= (unsigned char)buf[i];
        x *= 1099511628211ULL;
    }
    return (long long)x;
}

int dc_rename(const char *from, const char *to) { return rename(from, to) == 0 ? 0 : errno; }

/* Bytes and inodes (files) that an unprivileged user may still create on the file system
 * of path; -1 in either for a file system that does not tell (f_favail = 0 with
 * f_files = 0, as on some network and FUSE file systems). */
int dc_free_space(const char *path, int64_t *bytes, int64_t *files)
{
    struct statvfs s;
    if (statvfs(path, &s) != 0) return errno;
    *bytes = (int64_t)s.f_bavail * (int64_t)(s.f_frsize ? s.f_frsize : s.f_bsize);
    *files = s.f_files == 0 ? -1 : (int64_t)s.f_favail;
    return 0;
}

int dc_unlink(const char *path) { return unlink(path) == 0 || errno == ENOENT ? 0 : errno; }

/* 1 if the n characters at s are decimal digits making a number above `after`. */
static int number_after(const char *s, size_t n, long long after)
{
    unsigned long long v = 0;
    if (n == 0) return 0;
    for (size_t i = 0; i < n; i++) {
        if (s[i] < '0' || s[i] > '9') return 0;
        if (v > (unsigned long long)INT64_MAX / 10) return 1;   /* far above any step */
        v = v * 10 + (unsigned long long)(s[i] - '0');
    }
    return v > (unsigned long long)after;
}

/* Remove the files of folder dir whose names start with prefix and end with suffix (a
 * missing folder holds none); with after >= 0, only those whose name between prefix and
 * suffix is a number above after (the snapshots of steps after a checkpoint's). Returns 0
 * or the first errno met (the others are still tried). */
int dc_remove_matching(const char *dir, const char *prefix, const char *suffix,
                       long long after)
{
    DIR *d = opendir(dir);
    struct dirent *e;
    size_t lp = strlen(prefix), ls = strlen(suffix), ld = strlen(dir);
    int err = 0;
    if (d == NULL) return errno == ENOENT || errno == ENOTDIR ? 0 : errno;
    while ((e = readdir(d)) != NULL) {
        size_t n = strlen(e->d_name);
        if (n < lp + ls || strncmp(e->d_name, prefix, lp) != 0
            || strcmp(e->d_name + n - ls, suffix) != 0)
            continue;
        if (after >= 0 && !number_after(e->d_name + lp, n - lp - ls, after))
            continue;
        char *path = malloc(ld + n + 2);
        if (path == NULL) { err = err ? err : ENOMEM; continue; }
        snprintf(path, ld + n + 2, "%s/%s", dir, e->d_name);
        if (unlink(path) != 0 && errno != ENOENT && err == 0) err = errno;
        free(path);
    }
    closedir(d);
    return err;
}

/* 1 if paths a and b name the same existing folder or file (same device and inode:
 * "k", "k/", "./k", its absolute path or a symbolic link to it), 0 if they name two
 * existing ones, -1 if either does not exist (the caller compares the names then). */
int dc_same_file(const char *a, const char *b)
{
    struct stat sa, sb;
    if (stat(a, &sa) != 0 || stat(b, &sb) != 0) return -1;
    return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
}

/* 0 if path does not exist or is writable by us, else errno of access(W_OK). */
int dc_check_writable(const char *path)
{
    if (access(path, F_OK) != 0) return 0;
    return access(path, W_OK) == 0 ? 0 : errno;
}

/* Short text of an errno value, copied into msg (len bytes, blank-padded for Fortran). */
void dc_strerror(int err, char *msg, int len)
{
    const char *s = strerror(err);
    int i, n = (int)strlen(s);
    for (i = 0; i < len; i++) msg[i] = i < n ? s[i] : ' ';
}

/* The kernel's boot id into out (n bytes); 0 on success, -1 where /proc does not tell. */
static int dc_boot_id(char *out, size_t n)
{
    ssize_t r;
    int fd = open("/proc/sys/kernel/random/boot_id", O_RDONLY | O_CLOEXEC);
    if (fd < 0) return -1;
    r = read(fd, out, n - 1);
    close(fd);
    if (r <= 0) return -1;
    out[r] = '\0';
    out[strcspn(out, "\n")] = '\0';
    return 0;
}

/* 1 if a lock written on host `host` with boot id `boot` comes from another machine: its
 * host name is not ours and its boot id is not ours either (a container of this machine
 * has another host name but the same kernel, whose pids we may check). */
static int dc_other_machine(const char *host, const char *boot)
{
    char mine[256], my_boot[64];
    if (*host == '\0' || gethostname(mine, sizeof mine) != 0) return 0;
    mine[sizeof mine - 1] = '\0';
    if (strcmp(host, mine) == 0) return 0;
    return dc_boot_id(my_boot, sizeof my_boot) != 0 || strcmp(boot, my_boot) != 0;
}

/* "STARTTIME BOOT_ID" of process pid (its start in clock ticks after boot, field 22 of
 * /proc/PID/stat, and the kernel's boot id) into out; 0 on success, -1 where /proc does
 * not tell (another system, a process already gone). */
static int dc_proc_identity(long pid, char *out, size_t n)
{
    char name[64], stat[1024], boot[64];
    unsigned long long start = 0;
    ssize_t r;
    int fd, field;
    char *p;
    snprintf(name, sizeof name, "/proc/%ld/stat", pid);
    fd = open(name, O_RDONLY | O_CLOEXEC);
    if (fd < 0) return -1;
    r = read(fd, stat, sizeof stat - 1);
    close(fd);
    if (r <= 0) return -1;
    stat[r] = '\0';
    p = strrchr(stat, ')');              /* the command name may hold blanks and ')' */
    if (p == NULL) return -1;
    for (field = 2; field < 22 && p != NULL; field++) p = strchr(p + 1, ' ');
    if (p == NULL || sscanf(p + 1, "%llu", &start) != 1) return -1;
    if (dc_boot_id(boot, sizeof boot) != 0) return -1;
    snprintf(out, n, "%llu %s", start, boot);
    return 0;
}

/* Take the lock file path: created with O_EXCL, holding "PID STARTTIME BOOT_ID HOST"
 * (just "PID" where /proc does not tell; no HOST where the machine has no name). A lock
 * whose pid is not a live process (stale, e.g. after kill -9), or is a live process with
 * another start time or boot id (the pid reused after a kill -9 or a reboot), is taken
 * over. A lock written on another machine (an output folder on a file system that
 * several machines share, the nodes of a cluster) is held: its pid cannot be checked
 * from here, and two runs must not write into one folder.
 * Returns 0 (taken), -pid (held by the live process pid, or by pid on another machine:
 * dc_lock_host names it) or errno (> 0). */
int dc_lock_take(const char *path)
{
    char buf[512], mine[128], theirs[128], host[256];
    int attempt;
    if (gethostname(host, sizeof host) != 0) host[0] = '\0';
    host[sizeof host - 1] = '\0';
    if (strchr(host, ' ') || strchr(host, '\n')) host[0] = '\0';
    for (attempt = 0; attempt < 3; attempt++) {
        int fd = open(path, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
        if (fd >= 0) {
            int n = dc_proc_identity((long)getpid(), mine, sizeof mine) == 0
                        ? snprintf(buf, sizeof buf, "%ld %s%s%s\n", (long)getpid(), mine,
                                   *host ? " " : "", host)
                        : snprintf(buf, sizeof buf, "%ld\n", (long)getpid());
            int err = dc_fd_write(fd, buf, n);
            int err2 = dc_fd_close(fd);
            if (err == 0) err = err2;
            if (err != 0) unlink(path);
            return err;
        }
        if (errno != EEXIST) return errno;
        /* Held: by whom? */
        fd = open(path, O_RDONLY | O_CLOEXEC);
        if (fd < 0) {
            if (errno == ENOENT) continue;   /* released meanwhile: try again */
            return errno;
        }
        ssize_t r = read(fd, buf, sizeof buf - 1);
        close(fd);
        long pid = 0;
        char *rest = buf;
        if (r > 0) {
            buf[r] = '\0';
            pid = strtol(buf, &rest, 10);
            while (*rest == ' ') rest++;
            rest[strcspn(rest, "\n")] = '\0';
        }
        if (pid <= 0) {
            /* Being written by its owner right now (O_EXCL then write): treat as held
             * unless it stays empty; an empty file left by a crash is taken over on the
             * next attempt only if it is older than a second. */
            struct stat st;
            if (stat(path, &st) == 0 && st.st_size == 0) {
                usleep(100000);
                if (stat(path, &st) == 0 && st.st_size == 0) {
                    unlink(path);
                    continue;
                }
            }
            continue;
        }
        char lock_start[32] = "", lock_boot[64] = "", lock_host[256] = "";
        int k = sscanf(rest, "%31s %63s %255s", lock_start, lock_boot, lock_host);
        if (k == 3 && dc_other_machine(lock_host, lock_boot)) return (int)-pid;
        if (kill((pid_t)pid, 0) == 0 || errno == EPERM) {
            /* Alive: the owner unless the lock names another start or boot of that pid. */
            char identity[128];
            snprintf(identity, sizeof identity, "%s%s%s", lock_start, k >= 2 ? " " : "",
                     lock_boot);
            if (*rest == '\0' || dc_proc_identity(pid, theirs, sizeof theirs) != 0
                || strcmp(identity, theirs) == 0)
                return (int)-pid;
        }
        /* Stale: the process is gone, or the pid is another process now. Remove and
         * try again. */
        unlink(path);
    }
    return EEXIST;
}

/* The host name of the machine that wrote the lock file path, blank-padded into out
 * (len bytes), when that is another machine (dc_lock_take holds such a lock); 1 then,
 * else 0 (out blank). */
int dc_lock_host(const char *path, char *out, int len)
{
    char buf[512], start[32] = "", boot[64] = "", host[256] = "";
    long pid;
    int i, n, fd = open(path, O_RDONLY | O_CLOEXEC);
    ssize_t r = fd < 0 ? -1 : read(fd, buf, sizeof buf - 1);
    for (i = 0; i < len; i++) out[i] = ' ';
    if (fd >= 0) close(fd);
    if (r <= 0) return 0;
    buf[r] = '\0';
    if (sscanf(buf, "%ld %31s %63s %255s", &pid, start, boot, host) != 4
        || !dc_other_machine(host, boot))
        return 0;
    n = (int)strlen(host);
    for (i = 0; i < len && i < n; i++) out[i] = host[i];
    return 1;
}

/* Remove the lock file if it holds our pid. */
int dc_lock_release(const char *path)
{
    char buf[160];
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0) return 0;
    ssize_t r = read(fd, buf, sizeof buf - 1);
    close(fd);
    if (r <= 0) return 0;
    buf[r] = '\0';
    if (strtol(buf, NULL, 10) != (long)getpid()) return 0;
    return dc_unlink(path);
}

/* Format x exactly as Fortran's es24.16e3 edit descriptor does (24 characters: sign or
 * blank, d.dddddddddddddddd, E, exponent sign, 3 digits; correctly rounded to 17
 * significant digits), into out[0..23]. Returns 1, or 0 when x is not handled here
 * (not finite, a decimal exponent below -28 or above 38, or a value within 1e-6 of a
 * rounding tie): the caller then uses the Fortran edit descriptor itself. Why: a trace
 * row holds 9 reals, and libgfortran's formatted output costs ~0.8 us per real (about
 * 10 k instructions), more than ten times this path.
 * How: with p = 10^k exact (|k| <= 22), a*p = hi + lo exactly (fma), or a/p = q + r/p
 * with r = fma(-q, p, a) exact; for 22 < k <= 44 (small values, such as a velocity or a
 * contact energy near zero), a*10^22*10^(k-22) in the same way, with an error far below
 * the tie guard; the integer part and the rounding come from hi and lo. */
static const double dc_pow10[23] = {1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10,
    1e11, 1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};

int dc_format_es(double x, char *out)
{
    double a = fabs(x), hi, lo, h, rem;
    long long n;
    int e10, k, i, tries;
    if (!isfinite(x)) return 0;
    if (a == 0.0) {
        memcpy(out, " 0.0000000000000000E+000", 24);
        if (signbit(x)) out[0] = '-';
        return 1;
    }
    {   /* floor(log10(a)) or one less, from the binary exponent (the loop below
         * corrects it); subnormals give e10 = -308, which is left to the caller */
        uint64_t bits;
        memcpy(&bits, &a, sizeof bits);
        e10 = (int)floor((double)((int)((bits >> 52) & 0x7ff) - 1023) * 0.30102999566398120);
    }
    for (tries = 0; tries < 3; tries++) {
        k = 16 - e10;
        if (k >= 0 && k <= 22) {
            hi = a * dc_pow10[k];
            lo = fma(a, dc_pow10[k], -hi);
        } else if (k > 22 && k <= 44) {
            /* two exact powers: a 10^22 = h1 + l1 exactly, then (h1 + l1) 10^(k-22) =
             * hi + lo with only l1 10^(k-22) rounded (an error of ~1e-15 of the last digit) */
            double h1 = a * dc_pow10[22], l1 = fma(a, dc_pow10[22], -h1);
            hi = h1 * dc_pow10[k - 22];
            lo = fma(h1, dc_pow10[k - 22], -hi) + l1 * dc_pow10[k - 22];
        } else if (k < 0 && k >= -22) {
            hi = a / dc_pow10[-k];
            lo = fma(-hi, dc_pow10[-k], a) / dc_pow10[-k];
        } else {
            return 0;
        }
        if (hi >= 9.0e18) { e10++; continue; }
        h = floor(hi);                 /* integer arithmetic from here: h may be >= 2^53 */
        rem = (hi - h) + lo;
        n = (long long)h + (long long)floor(rem);
        rem -= floor(rem);
        if (fabs(rem - 0.5) < 1e-6) return 0;
        n += rem > 0.5 ? 1 : 0;
        if (n < 10000000000000000LL) { e10--; continue; }
        if (n >= 100000000000000000LL) {
            if (n == 100000000000000000LL && rem > 0.5) {
                n = 10000000000000000LL;   /* rounded up to the next decade */
                e10++;
                break;
            }
            e10++;
            continue;
        }
        break;
    }
    if (tries == 3 || e10 > 999 || e10 < -999) return 0;
    out[0] = signbit(x) ? '-' : ' ';
    for (i = 18; i >= 3; i--) { out[i] = (char)('0' + n % 10); n /= 10; }
    out[1] = (char)('0' + n);
    out[2] = '.';
    out[19] = 'E';
    out[20] = e10 < 0 ? '-' : '+';
    k = e10 < 0 ? -e10 : e10;
    out[21] = (char)('0' + k / 100);
    out[22] = (char)('0' + (k / 10) % 10);
    out[23] = (char)('0' + k % 10);
    return 1;
}
