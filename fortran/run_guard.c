/* run_guard.c: the few POSIX calls the Fortran core needs and Fortran cannot make
 * itself (bound through bind(C) in run_files.f90 and main.f90):
 *   - SIGINT / SIGTERM handlers that only set a flag, polled at the end of each step;
 *   - an output-folder lock file created with O_EXCL that holds the owner's pid;
 *   - whole-buffer writes to a file descriptor (every error reported, EINTR retried),
 *     close, rename and unlink with their errno, so that a full disk is never silent.
 * Every function returns 0 on success and errno (> 0) on failure unless said otherwise. */
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <unistd.h>

static volatile sig_atomic_t dc_signal_flag = 0;

static void dc_on_signal(int sig) { dc_signal_flag = sig; }

/* Install the SIGINT and SIGTERM handlers (executable only). */
int dc_signals_install(void)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = dc_on_signal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESTART;
    if (sigaction(SIGINT, &sa, NULL) != 0) return errno;
    if (sigaction(SIGTERM, &sa, NULL) != 0) return errno;
    return 0;
}

/* The signal caught since the handlers were installed (0 = none). */
int dc_signal_caught(void) { return (int)dc_signal_flag; }

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

int dc_rename(const char *from, const char *to) { return rename(from, to) == 0 ? 0 : errno; }

int dc_unlink(const char *path) { return unlink(path) == 0 || errno == ENOENT ? 0 : errno; }

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

/* Take the lock file path: created with O_EXCL, holding our pid. A lock whose pid is
 * not a live process (stale, e.g. after kill -9) is taken over.
 * Returns 0 (taken), -pid (held by the live process pid) or errno (> 0). */
int dc_lock_take(const char *path)
{
    char buf[32];
    int attempt;
    for (attempt = 0; attempt < 3; attempt++) {
        int fd = open(path, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
        if (fd >= 0) {
            int n = snprintf(buf, sizeof buf, "%ld\n", (long)getpid());
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
        if (r > 0) {
            buf[r] = '\0';
            pid = strtol(buf, NULL, 10);
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
        if (kill((pid_t)pid, 0) == 0 || errno == EPERM) return (int)-pid;
        /* Stale: the process is gone. Remove and try again. */
        unlink(path);
    }
    return EEXIST;
}

/* Remove the lock file if it holds our pid. */
int dc_lock_release(const char *path)
{
    char buf[32];
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0) return 0;
    ssize_t r = read(fd, buf, sizeof buf - 1);
    close(fd);
    if (r <= 0) return 0;
    buf[r] = '\0';
    if (strtol(buf, NULL, 10) != (long)getpid()) return 0;
    return dc_unlink(path);
}
