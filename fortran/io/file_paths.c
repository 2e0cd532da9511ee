/* file_paths.c: the canonical form of a path (realpath: absolute, with '.', '..' and
 * symbolic links resolved), bound through bind(C) in os_files.f90. The .geo command scan
 * (gmsh_mesh.f90, scan_geo) keys the files it has scanned by it, so that one file
 * written two ways ('a.geo', './a.geo', 'sub/../a.geo', a link to it) is one file. */
#include <stdlib.h>
#include <string.h>

/* The canonical form of path copied into out (len bytes, NUL-terminated): its length,
 * or -1 when path cannot be resolved (missing, unreadable folder) or does not fit. */
int dc_real_path(const char *path, char *out, int len)
{
    char *r = realpath(path, NULL);
    size_t n;
    if (r == NULL) return -1;
    n = strlen(r);
    if (len <= 0 || n >= (size_t)len) {
        free(r);
        return -1;
    }
    memcpy(out, r, n + 1);
    free(r);
    return (int)n;
}
