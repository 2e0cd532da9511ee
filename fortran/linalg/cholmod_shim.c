/* Flat C interface to CHOLMOD (SuiteSparse 5.12, CHOLMOD 3.0) for fortran/linalg/cholmod.f90.
 *
 * cholmod_common is a large C struct whose layout depends on the build, so Fortran never
 * sees it: one dc_cholmod handle owns the common block, the factor (the symbolic
 * analysis is reused while the pattern stays the same: n, the number of entries and two
 * 64-bit hashes of the pattern are kept, not a copy of it) and the dense workspaces of
 * cholmod_solve2 (no allocation per solve).
 *
 * Factorization: simplicial LDL' (Common->supernodal = CHOLMOD_SIMPLICIAL,
 * final_ll = FALSE), made by cholmod_rowfac a range of rows at a time, so that only a
 * range's columns of the permuted matrix are held next to the factor (factor_by_ranges;
 * the factor of cholmod_factorize bit for bit), or supernodal LL' when the factor's
 * columns are long (use_supernodal: 3D meshes from some 10^4 dofs on; a matrix without
 * node blocks only when its factor serves a few solves). Only the upper triangle of the
 * CSC matrix is read (stype = +1): pass the full symmetric matrix or its upper triangle.
 *
 * Node blocks: when the dofs 2k, 2k+1 (0-based) come in pairs whose 2x2 blocks are all
 * stored (the free dofs of the nodes of a 2D mesh), or else the dofs 3k, 3k+1, 3k+2 in
 * triples whose 3x3 blocks are all stored (3D), the ordering is one of the graph of the
 * node blocks, each block kept together (no postordering): AMD's, CHOLMOD's nested
 * dissection or (triples only) METIS's, whichever gives L the fewest entries
 * (analyze_blocks); the supernodes are then not relaxed. L is then made of full 2x2
 * (3x3) blocks, which dc_cholmod_take_blocks turns in place into the layout that
 * fortran/linalg/ldl_solves.f90 solves with (one copy of the factor at any time;
 * dc_cholmod_export copies it instead, when the caller keeps CHOLMOD's factor). Pairs are
 * tried first: a matrix made of node pairs is never ordered as triples.
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <math.h>
#include <pthread.h>
#include "cholmod.h"

int omp_get_thread_limit(void);   /* libgomp's (omp.h without -fopenmp) */
#ifdef __GLIBC__
#include <malloc.h>
#endif

typedef struct {
    cholmod_common c;
    cholmod_factor *L;
    int n;
    int nnz;
    unsigned long long hash[2]; /* two hashes of the analysed pattern (reuse test) */
    cholmod_dense *B, *X, *Y, *E;   /* solve2 right-hand side header and workspaces */
    int bcols;             /* columns of B */
    int paired;            /* the analysis ordered node blocks together: their size (2, 3), or 0 */
    int ordering;          /* the ordering of the analysis (ORD_*) */
    int super;             /* the factorization is CHOLMOD's supernodal LL' (else simplicial LDL') */
    int few_solves;        /* the factor serves a few solves only (dc_cholmod_few_solves) */
    double entries;        /* entries of the analysed factor (D and L: its column counts) */
    int *bi;               /* the blocks' rows taken from a supernodal factor (else NULL) */
    int taken;             /* L's values and rows were turned into node blocks in place
                            * (dc_cholmod_take_blocks): L's numeric part is not a factor
                            * any more, its x and i are lent to the caller */
    double need[4];        /* bytes the factorization that ran out of memory was to hold
                            * (dc_cholmod_need): the factor, its work, the BLAS's buffer,
                            * the threads' stacks */
} dc_cholmod;

/* Statuses returned to Fortran: DC_OUT_OF_MEMORY in the numerical factorization,
 * DC_OUT_OF_MEMORY_ORDERING in the symbolic analysis (the orderings), DC_INTERRUPTED
 * when the stop flag was set (a SIGINT / SIGTERM, base/stop_signal.c) before an
 * ordering tried, before the numerical factorization or before a range of rows of a
 * simplicial one: no factor kept. */
enum { DC_OK = 0, DC_NOT_POSDEF = 1, DC_OUT_OF_MEMORY = 2, DC_FAILED = 3,
       DC_OUT_OF_MEMORY_ORDERING = 4, DC_INTERRUPTED = 5 };

int dc_signal_caught(void);   /* base/stop_signal.c: the stop flag (0 = none) */

/* Out of memory in a library that cannot say so. The first BLAS call of the process
 * (LAPACK's dpotrf in CHOLMOD's supernodal factorization; UMFPACK's dgemm) makes
 * OpenBLAS allocate its buffer (BLAS_BUFFER bytes: 128 MiB and a page in OpenBLAS 0.3 on
 * x86-64), and OpenBLAS retries a failed allocation for ever (a run under a limit of the
 * address space hangs there); the supernodal factorization's OpenMP loops start
 * CHOLMOD_OMP_NUM_THREADS - 1 helper threads (4 - 1 in Debian's build, whatever
 * OMP_NUM_THREADS says), whose stacks count against that limit, and libgomp ends the
 * process (exit status 1, "Thread creation failed") when one cannot be made. Both
 * happen once a process (the buffer and the threads are kept), so before the first
 * supernodal factorization the room for them, with the factor's, is asked for first
 * (dc_room) and a refusal is an ordinary out of memory. These flags say they were made. */
#define BLAS_BUFFER ((double) (128 << 20) + (1 << 20))
static int blas_buffer_made = 0;
static int omp_threads_made = 0;

/* The bytes of a thread's stack (the default of new threads: RLIMIT_STACK, or
 * OMP_STACKSIZE / GOMP_STACKSIZE, not read here: set larger, the check is short of
 * them) and a guard page. */
static double thread_stack_bytes(void)
{
    pthread_attr_t attr;
    size_t size = 8u << 20;
    if (pthread_getattr_default_np(&attr) == 0) {
        if (pthread_attr_getstacksize(&attr, &size) != 0) size = 8u << 20;
        pthread_attr_destroy(&attr);
    }
    return (double) size + 4096.0;
}

/* The bytes the BLAS's buffer will take: BLAS_BUFFER where the BLAS is OpenBLAS and has
 * not made it yet, else 0 (the reference BLAS allocates nothing). */
void dc_cholmod_blas(char *msg, int len);

static double blas_buffer_bytes(void)
{
    char text[1024];
    if (blas_buffer_made) return 0.0;
    dc_cholmod_blas(text, (int) sizeof text - 1);
    text[sizeof text - 1] = '\0';
    return strstr(text, "OpenBLAS") != NULL ? BLAS_BUFFER : 0.0;
}

/* The threads of CHOLMOD's OpenMP loops: CHOLMOD_OMP_NUM_THREADS, at most OpenMP's
 * thread limit (OMP_THREAD_LIMIT; OMP_NUM_THREADS does not lower it). */
static int omp_helpers(void)
{
    int limit = omp_get_thread_limit();
    return limit < CHOLMOD_OMP_NUM_THREADS ? (limit > 1 ? limit : 1) : CHOLMOD_OMP_NUM_THREADS;
}

/* Whether `bytes` could be allocated now (allocated and freed at once, never touched:
 * under a limit of the address space this is the test; without one it costs nothing
 * but the call). */
static int dc_room(double bytes)
{
    void *p;
    if (bytes <= 0) return 1;
    if (bytes > (double) ((size_t) -1 / 2)) return 0;
    p = malloc((size_t) bytes);
    if (p == NULL) return 0;
    free(p);
    return 1;
}

/* Whether BLAS_BUFFER bytes are free when the BLAS has not made its buffer yet (see
 * BLAS_BUFFER): UMFPACK asks before its numerical factorization. 1 when it may go on. */
int dc_blas_room(double extra)
{
    return dc_room(extra + blas_buffer_bytes());
}

/* UMFPACK's numerical factorization went through: the BLAS has its buffer. */
void dc_blas_made(void) { blas_buffer_made = 1; }

/* New handle (NULL when out of memory). */
void *dc_cholmod_new(void)
{
    dc_cholmod *h = calloc(1, sizeof(dc_cholmod));
    if (h == NULL) return NULL;
    cholmod_start(&h->c);
    h->c.print = 0;                       /* the caller reports errors */
    h->c.supernodal = CHOLMOD_SIMPLICIAL;
    h->c.final_ll = 0;                    /* keep LDL' */
    h->c.final_pack = 1;
    h->c.final_monotonic = 1;
    /* METIS ends the process (abort) when an allocation fails: CHOLMOD first asks for
     * METIS's observed upper bound, (10 nz + 50 n + 4096) indices, and where that is
     * refused the ordering is out of memory (analyze_blocks then keeps another) */
    h->c.metis_memory = 1.0;
    return h;
}

static void free_dense(dc_cholmod *h)
{
    if (h->X) cholmod_free_dense(&h->X, &h->c);
    if (h->Y) cholmod_free_dense(&h->Y, &h->c);
    if (h->E) cholmod_free_dense(&h->E, &h->c);
    free(h->B);
    h->B = NULL;
    h->bcols = 0;
}

/* The factor's numerical values go (the symbolic analysis stays, supernodal or
 * simplicial, for the next factorization), with the blocks' rows taken from them. */
static int release_values(dc_cholmod *h)
{
    free(h->bi);
    h->bi = NULL;
    h->taken = 0;
    if (h->L == NULL || h->L->xtype == CHOLMOD_PATTERN) return 1;
    return cholmod_change_factor(CHOLMOD_PATTERN, h->L->is_ll, h->L->is_super, 1, 1, h->L,
                                 &h->c);
}

static void free_factor(dc_cholmod *h)
{
    free(h->bi);
    h->bi = NULL;
    if (h->L) cholmod_free_factor(&h->L, &h->c);
    h->taken = 0;
    h->super = 0;
    h->hash[0] = h->hash[1] = 0;
    h->n = 0;
    h->nnz = 0;
    h->entries = 0;
    free_dense(h);
}

/* Release everything (NULL is allowed). */
void dc_cholmod_free(void *handle)
{
    dc_cholmod *h = handle;
    if (h == NULL) return;
    free_factor(h);
    cholmod_finish(&h->c);
    free(h);
}

/* A CSC header over caller-owned arrays (0-based, sorted rows, upper triangle read). */
static void csc_header(cholmod_sparse *a, int n, const int *colptr, const int *rowind,
                       const double *val)
{
    memset(a, 0, sizeof(*a));
    a->nrow = (size_t) n;
    a->ncol = (size_t) n;
    a->nzmax = (size_t) (colptr[n] > 0 ? colptr[n] : 1);
    a->p = (void *) colptr;
    a->i = (void *) rowind;
    a->x = (void *) val;
    a->stype = 1;
    a->itype = CHOLMOD_INT;
    a->xtype = val != NULL ? CHOLMOD_REAL : CHOLMOD_PATTERN;
    a->dtype = CHOLMOD_DOUBLE;
    a->sorted = 1;
    a->packed = 1;
}

/* Whether the upper triangle of the pattern is made of whole bs x bs blocks of the node
 * blocks (bs k, ..., bs k + bs - 1): the bs columns of block J hold the same rows above
 * bs J, those rows come in whole blocks, and the diagonal block's upper triangle is
 * stored (rows bs J .. c in column c). */
static int blocks_pattern(int n, int bs, const int *colptr, const int *rowind)
{
    int J, r, t;
    if (n < bs || n % bs != 0) return 0;
    for (J = 0; bs * J < n; J++) {
        int c0 = bs * J;
        int p0 = colptr[c0], pe0 = colptr[c0 + 1];
        int nabove = 0;
        /* column c0: whole blocks above the diagonal block */
        while (p0 + nabove < pe0 && rowind[p0 + nabove] < c0) {
            int q = p0 + nabove;
            if (rowind[q] % bs != 0 || q + bs > pe0) return 0;
            for (t = 1; t < bs; t++)
                if (rowind[q + t] != rowind[q] + t) return 0;
            nabove += bs;
        }
        /* every column of the block: the same rows above, then its diagonal block part */
        for (r = 0; r < bs; r++) {
            int c = c0 + r, p = colptr[c], pe = colptr[c + 1];
            if (pe - p < nabove + r + 1) return 0;
            for (t = 0; t < nabove; t++)
                if (rowind[p + t] != rowind[p0 + t]) return 0;
            for (t = 0; t <= r; t++)
                if (rowind[p + nabove + t] != c0 + t) return 0;
        }
    }
    return 1;
}

/* Entries of a symbolic simplicial factor (its column counts, diagonal included). */
static double h_lnz(const cholmod_factor *L)
{
    const int *cc = L->ColCount;
    double k = 0;
    size_t j;
    for (j = 0; j < L->n; j++) k += cc[j];
    return k;
}

/* The supernodal factorization (CHOLMOD's supernodal LL', BLAS-3 on the dense blocks
 * of columns that share a pattern) is used when the factor's columns hold at least this
 * many entries on average (D included; from the simplicial symbolic analysis). Its
 * numerical factorization, measured against the simplicial LDL' on the same ordering
 * (docs/performance.md, "One copy of the factor, the supernodal factorization, and the
 * set-up's peak"): slower at 42.5 entries a column (2D strip, 129 600 dofs: 0.51 s
 * against 0.44 s) and 77 (3D box, 3 000 dofs), 1.5x
 * faster at 249 (3D box, 19 440 dofs: 0.61 s against 0.93 s); the factor's columns
 * grow with the mesh in 3D, and so does the gain. Either way the factor is then solved
 * by the same node-block kernels (dc_cholmod_take_blocks turns LL' into LDL'). */
#define SUPERNODAL_MIN_COLUMN 150.0

/* The same rule for a factor without node blocks (a scalar matrix: the node matrix S of
 * a mass M = S (x) I_d) whose factor serves a few solves only (dc_cholmod_few_solves: the
 * Newmark family's initial acceleration, freed after one solve). Its numerical
 * factorization with the ordering of cholmod_analyze (ordering, factorization and one
 * solve timed, best of 3, the two alternating; docs/performance.md, "Where the set-up's
 * time goes"): slower at 24-27 entries a column (2D, 40 401 and 64 881 nodes: 0.34 s
 * against 0.72 s), 70 and 90 (3D, 1 331 and 6 561 nodes: 1.1-1.4x), within the machine's
 * noise at 116-126, 1.5-2x faster at 140-146 (3D, 4 096-6 929 nodes), 3-3.7x at 162-211
 * (3D, 9 261-25 856 nodes: 1.2 s against 4.5 s at 17 576). Its solves by cholmod_solve2
 * are slower (the 3D cube at 9 261 nodes: 11.7-13.2 ms against 8.8-10.5 ms for 3
 * right-hand sides), which is why a factor kept for every step (pc, central) stays
 * simplicial. */
#define SCALAR_SUPERNODAL_MIN_COLUMN 110.0

/* Orderings of the node blocks' graph (dc_cholmod_ordering's codes). */
enum { ORD_NONE = 0, ORD_AMD = 1, ORD_METIS = 2, ORD_NESDIS = 3, ORD_CHOLMOD = 4 };

/* The ordering DYNCONTACT_ORDERING forces ('amd', 'metis', 'nesdis'), or ORD_NONE (the
 * analysis picks): a test-only switch, to check that every ordering gives the same
 * results to round-off. */
static int forced_ordering(void)
{
    const char *e = getenv("DYNCONTACT_ORDERING");
    if (e == NULL) return ORD_NONE;
    if (strcmp(e, "amd") == 0) return ORD_AMD;
    if (strcmp(e, "metis") == 0) return ORD_METIS;
    if (strcmp(e, "nesdis") == 0) return ORD_NESDIS;
    return ORD_NONE;
}

/* The factorization DYNCONTACT_FACTORIZATION forces: 1 'supernodal', 0 'simplicial', -1
 * unset or anything else (the rule of use_supernodal picks): a test-only switch, to
 * check that both give the same results to round-off. */
static int forced_factorization(void)
{
    const char *e = getenv("DYNCONTACT_FACTORIZATION");
    if (e == NULL) return -1;
    if (strcmp(e, "supernodal") == 0) return 1;
    if (strcmp(e, "simplicial") == 0) return 0;
    return -1;
}

/* Whether to factorize supernodally, from the simplicial symbolic factor L: see
 * SUPERNODAL_MIN_COLUMN. A factor made of node blocks (blocks = their size, else 0) is
 * solved by the same kernels either way; a factor without them is solved by
 * cholmod_solve2, which was measured slower on the supernodal factor, so it is
 * factorized supernodally only when it serves a few solves (few_solves; see
 * SCALAR_SUPERNODAL_MIN_COLUMN). */
static int use_supernodal(const cholmod_factor *L, int blocks, int few_solves)
{
    int f = forced_factorization();
    if (f >= 0) return f;
    if (blocks > 0) return h_lnz(L) >= SUPERNODAL_MIN_COLUMN * (double) L->n;
    return few_solves && h_lnz(L) >= SCALAR_SUPERNODAL_MIN_COLUMN * (double) L->n;
}

/* Order the node blocks' graph g with ordering ord into nperm (1 on success). */
static int order_pairs(cholmod_sparse *g, int ord, int *nperm, cholmod_common *c)
{
    int nn = (int) g->nrow, ok = 0;
    int *cp, *cm;
    switch (ord) {
    case ORD_AMD:
        return cholmod_amd(g, NULL, 0, nperm, c);
    case ORD_METIS:
        return cholmod_metis(g, NULL, 0, 0, nperm, c);
    case ORD_NESDIS:
        cp = malloc(sizeof(int) * (size_t) nn);
        cm = malloc(sizeof(int) * (size_t) nn);
        if (cp != NULL && cm != NULL)
            ok = cholmod_nested_dissection(g, NULL, 0, nperm, cp, cm, c) >= 0;
        free(cp);
        free(cm);
        return ok;
    default:
        return 0;
    }
}

/* Analysis with a fill-reducing ordering of the graph of the node blocks of size bs
 * (each block kept together, no postordering, so that L is made of bs x bs blocks).
 * AMD and CHOLMOD's nested dissection (and for triples METIS) are tried, each by a
 * symbolic analysis alone (the column counts of L, no numerical factorization), and the
 * ordering with the fewest entries in L is kept (AMD on a tie; the solves' cost is proportional to those entries,
 * so the choice is the one that solves fastest, and it depends on the pattern alone:
 * deterministic). *ord = the ordering kept. NULL on failure. */
static cholmod_factor *analyze_blocks(cholmod_sparse *a, int bs, cholmod_common *c, int *ord)
{
    int n = (int) a->nrow, nn = n / bs, J, p, cnt = 0, k, t;
    const int *colptr = a->p, *rowind = a->i;
    int *np = malloc(sizeof(int) * (size_t) (nn + 1));
    int *ni = malloc(sizeof(int) * (size_t) (colptr[n] > 0 ? colptr[n] : 1));
    int *nperm = malloc(sizeof(int) * (size_t) nn);
    int *perm = malloc(sizeof(int) * (size_t) n);
    cholmod_sparse g;
    cholmod_factor *L = NULL, *Lk;
    int nmethods = c->nmethods, ordering = c->method[0].ordering, postorder = c->postorder;
    int forced = forced_ordering();
    static const int tries[3] = { ORD_AMD, ORD_METIS, ORD_NESDIS };
    *ord = ORD_NONE;
    if (np == NULL || ni == NULL || nperm == NULL || perm == NULL) {
        c->status = CHOLMOD_OUT_OF_MEMORY;
        goto done;
    }
    /* the blocks' upper pattern: column J's rows are those of column bs J + bs - 1 up to
     * the diagonal, one a block, divided by bs */
    for (J = 0; J < nn; J++) {
        np[J] = cnt;
        for (p = colptr[bs * J + bs - 1]; p < colptr[bs * J + bs] && rowind[p] <= bs * J; p += bs)
            ni[cnt++] = rowind[p] / bs;
    }
    np[nn] = cnt;
    csc_header(&g, nn, np, ni, NULL);
    c->nmethods = 1;
    c->method[0].ordering = CHOLMOD_GIVEN;
    c->postorder = 0;
    for (k = 0; k < 3; k++) {
        if (dc_signal_caught()) {    /* stopped: no analysis (analyse says why) */
            if (L != NULL) cholmod_free_factor(&L, c);
            break;
        }
        if (forced != ORD_NONE && tries[k] != forced) continue;
        /* METIS is tried for node triples (3D) only: on the node pairs of 2D meshes,
         * CHOLMOD's nested dissection (built on METIS's node separators) gave fewer
         * entries than METIS at every size where either beat AMD, and METIS cost 0.3 s of
         * the 1.5 s set-up at 129 600 dofs (docs/performance.md) */
        if (forced == ORD_NONE && tries[k] == ORD_METIS && bs == 2) continue;
        c->status = CHOLMOD_OK;
        if (!order_pairs(&g, tries[k], nperm, c)) continue;
        for (J = 0; J < nn; J++)
            for (t = 0; t < bs; t++) perm[bs * J + t] = bs * nperm[J] + t;
        Lk = cholmod_analyze_p(a, perm, NULL, 0, c);
        if (Lk == NULL) continue;
        if (L == NULL || h_lnz(Lk) < h_lnz(L)) {
            if (L != NULL) cholmod_free_factor(&L, c);
            L = Lk;
            *ord = tries[k];
        } else {
            cholmod_free_factor(&Lk, c);
        }
    }
    c->nmethods = nmethods;
    c->method[0].ordering = ordering;
    c->postorder = postorder;
    if (L != NULL) c->status = CHOLMOD_OK;
done:
    free(np);
    free(ni);
    free(nperm);
    free(perm);
    return L;
}

/* Two independent 64-bit hashes of a CSC pattern (FNV-1a over colptr and rowind, and a
 * multiply-xorshift over the same words): the analysis is reused when n, the number of
 * entries and both hashes agree, where a copy of the pattern took 4 bytes an entry
 * (7 MB at 129 600 dofs) for the whole run (two patterns of the same size that differ
 * would have to agree in 128 bits of hashes). */
static void pattern_hash(int n, const int *colptr, const int *rowind, unsigned long long h[2])
{
    unsigned long long a = 1469598103934665603ULL, b = 0x9E3779B97F4A7C15ULL, w;
    int k, nnz = colptr[n];
    for (k = 0; k <= n + nnz; k++) {
        w = (unsigned long long) (unsigned int) (k <= n ? colptr[k] : rowind[k - n - 1]);
        a = (a ^ w) * 1099511628211ULL;
        b = (b ^ (w + (unsigned long long) k)) * 0xBF58476D1CE4E5B9ULL;
        b ^= b >> 31;
    }
    h[0] = a;
    h[1] = b;
}

/* The symbolic analysis of the n x n CSC matrix a (its pattern: colptr[n+1],
 * rowind[nnz]), redone only when n or the pattern changed (*analysed = 1 then): node
 * blocks ordered together when the pattern allows, the ordering with the fewest factor
 * entries, the supernodal analysis when use_supernodal says so. h->entries = the
 * factor's entries (D and L, from the column counts: what the numerical factorization
 * will store). Returns DC_OK, DC_OUT_OF_MEMORY, DC_INTERRUPTED (the stop flag set during
 * the orderings) or DC_FAILED (no analysis kept). */
static int analyse(dc_cholmod *h, cholmod_sparse *ap, int n, const int *colptr,
                   const int *rowind, int *analysed)
{
    cholmod_sparse a = *ap;
    int nnz = colptr[n], k;
    unsigned long long hash[2];
    *analysed = 0;
    pattern_hash(n, colptr, rowind, hash);
    if (h->L == NULL || h->n != n || h->nnz != nnz || h->hash[0] != hash[0]
        || h->hash[1] != hash[1]) {
        free_factor(h);
        h->c.status = CHOLMOD_OK;
        h->paired = blocks_pattern(n, 2, colptr, rowind) ? 2
                    : blocks_pattern(n, 3, colptr, rowind) ? 3 : 0;
        if (h->paired) {
            h->L = analyze_blocks(&a, h->paired, &h->c, &h->ordering);
        } else {
            h->L = cholmod_analyze(&a, &h->c);
            h->ordering = ORD_CHOLMOD;
        }
        h->super = 0;
        if (h->L != NULL && use_supernodal(h->L, h->paired, h->few_solves)) {
            /* the same ordering, analysed for the supernodal factorization (not
             * postordered: the node blocks stay in place) */
            int *perm = malloc(sizeof(int) * (size_t) n);
            int nmethods = h->c.nmethods, ordering = h->c.method[0].ordering;
            int postorder = h->c.postorder;
            size_t nrelax[3];
            double zrelax[3];
            cholmod_factor *Ls = NULL;
            if (perm != NULL) {
                memcpy(perm, h->L->Perm, sizeof(int) * (size_t) n);
                h->c.nmethods = 1;
                h->c.method[0].ordering = CHOLMOD_GIVEN;
                h->c.postorder = 0;
                h->c.supernodal = CHOLMOD_SUPERNODAL;
                /* fundamental supernodes (no relaxed amalgamation): L keeps the simplicial
                 * factor's pattern, node blocks included, and no zero is stored */
                for (k = 0; k < 3; k++) {
                    nrelax[k] = h->c.nrelax[k];
                    zrelax[k] = h->c.zrelax[k];
                    h->c.nrelax[k] = 0;
                    h->c.zrelax[k] = 0.0;
                }
                h->c.status = CHOLMOD_OK;
                Ls = cholmod_analyze_p(&a, perm, NULL, 0, &h->c);
                h->c.supernodal = CHOLMOD_SIMPLICIAL;
                for (k = 0; k < 3; k++) {
                    h->c.nrelax[k] = nrelax[k];
                    h->c.zrelax[k] = zrelax[k];
                }
                h->c.nmethods = nmethods;
                h->c.method[0].ordering = ordering;
                h->c.postorder = postorder;
                free(perm);
            }
            if (Ls != NULL && Ls->is_super) {
                cholmod_free_factor(&h->L, &h->c);
                h->L = Ls;
                h->super = 1;
            } else if (Ls != NULL) {
                cholmod_free_factor(&Ls, &h->c);
            }
            h->c.status = CHOLMOD_OK;
        }
        if (h->L == NULL) {
            int st = h->c.status;
            free_factor(h);
            if (dc_signal_caught()) return DC_INTERRUPTED;
            return st == CHOLMOD_OUT_OF_MEMORY ? DC_OUT_OF_MEMORY_ORDERING : DC_FAILED;
        }
        /* the orderings' workspace goes (the factorization allocates its own, smaller) */
        cholmod_free_work(&h->c);
        h->hash[0] = hash[0];
        h->hash[1] = hash[1];
        h->n = n;
        h->nnz = nnz;
        h->entries = h_lnz(h->L);
        *analysed = 1;
    }
    return DC_OK;
}

/* Rows of L made by one cholmod_rowfac call: triu(P A P')'s columns of a range hold
 * about 1/RANGES of its entries (see factor_by_ranges). */
#define RANGES 16

/* The number of ranges: RANGES, or DYNCONTACT_FACTOR_RANGES (a test-only switch: a
 * number >= 1 of ranges, 0 for cholmod_factorize whole, to check that the factor does
 * not depend on it). */
static int factor_ranges(void)
{
    const char *e = getenv("DYNCONTACT_FACTOR_RANGES");
    int r;
    if (e == NULL || *e == '\0') return RANGES;
    r = atoi(e);
    return r >= 0 ? r : RANGES;
}

/* Insertion sort of n (row, value) pairs by row (a column of triu(P A P'): tens of
 * entries). */
static void sort_column(int n, int *ri, double *rx)
{
    int a, b, r;
    double x;
    for (a = 1; a < n; a++) {
        r = ri[a];
        x = rx[a];
        for (b = a - 1; b >= 0 && ri[b] > r; b--) {
            ri[b + 1] = ri[b];
            rx[b + 1] = rx[b];
        }
        ri[b + 1] = r;
        rx[b + 1] = x;
    }
}

/* The end (exclusive) of the range of rows that starts at k0: rows are added while their
 * entries cnt[] keep the range's total within target (one row at least); *sum gets the
 * range's total. factor_by_ranges sizes its buffers and fills its ranges by it. */
static int range_end(const int *cnt, int n, int k0, long target, long *sum)
{
    int k1;
    *sum = 0;
    for (k1 = k0; k1 < n && (k1 == k0 || *sum + cnt[k1] <= target); k1++) *sum += cnt[k1];
    return k1;
}

/* Each entry a(r, c), r <= c, of A's upper triangle goes to column k = max(pinv r, pinv c)
 * of triu(P A P'), row min(pinv r, pinv c). For the columns k0 <= k < k1: without si,
 * counted in at[k]; with si and sx, stored at place at[k]++ (si the row, sx the value).
 * A's columns in order, so each column of triu(P A P') gets its entries in one order
 * for the count and the fill. */
static void triu_columns(const cholmod_sparse *a, const int *pinv, int k0, int k1, int *at,
                         int *si, double *sx)
{
    const int *ap = a->p, *ai = a->i;
    const double *ax = a->x;
    int n = (int) a->ncol, c, k, p, r, pr, pc, q;
    for (c = 0; c < n; c++) {
        pc = pinv[c];
        for (p = ap[c]; p < ap[c + 1]; p++) {
            r = ai[p];
            if (r > c) continue;
            pr = pinv[r];
            k = pr > pc ? pr : pc;
            if (k < k0 || k >= k1) continue;
            if (si == NULL) {
                at[k]++;
                continue;
            }
            q = at[k]++;
            si[q] = pr < pc ? pr : pc;
            sx[q] = ax[p];
        }
    }
}

/* The simplicial LDL' of P A P' (h->L simplicial, A's upper triangle read) as
 * cholmod_factorize makes it, with less memory. cholmod_factorize hands cholmod_rowfac
 * triu(P A P') whole (two transposes of A's upper triangle: 12 bytes an entry, alive
 * next to L while L is made, the set-up's peak). Here cholmod_rowfac makes the rows of
 * L a range at a time (kstart, kend: rows in order, so every row's descendants in the
 * elimination tree are done before it), and only that range's columns of triu(P A P')
 * are built, about 1/ranges of them. They are cholmod_factorize's columns: each entry
 * a(r, c), r <= c, of A's upper triangle at column max(pinv r, pinv c), row
 * min(pinv r, pinv c), rows sorted (what a transpose gives); rowfac reads each column in
 * that order, so L is the same bit for bit. Then, as cholmod_factorize does, L is
 * packed (final_pack, final_monotonic). Returns 1, or 0 (h->c.status says why; *stopped
 * = 1 when the stop flag was found set before a range, base/stop_signal.c). */
static int factor_by_ranges(dc_cholmod *h, const cholmod_sparse *a, int ranges, int *stopped)
{
    cholmod_factor *L = h->L;
    cholmod_sparse s = *a;
    const int *perm = L->Perm;
    int n = (int) L->n, k, k0, k1, status = CHOLMOD_OK, ok = 1;
    long total = 0, target, cap = 0, sum;
    int *pinv = malloc(sizeof(int) * (size_t) n);
    int *cnt = calloc((size_t) n, sizeof(int));
    int *sp = malloc(sizeof(int) * ((size_t) n + 1));
    int *si = NULL, *lnz;
    double *sx = NULL, beta[2] = {0.0, 0.0};
    size_t grow2 = h->c.grow2;
    if (pinv == NULL || cnt == NULL || sp == NULL) goto oom;
    for (k = 0; k < n; k++) pinv[perm[k]] = k;
    /* the entries of each column of triu(P A P') */
    triu_columns(a, pinv, 0, n, cnt, NULL, NULL);
    for (k = 0; k < n; k++) total += cnt[k];
    target = total / ranges + 1;
    for (k0 = 0; k0 < n; k0 = k1) {
        k1 = range_end(cnt, n, k0, target, &sum);
        if (sum > cap) cap = sum;
    }
    si = malloc(sizeof(int) * (size_t) (cap > 0 ? cap : 1));
    sx = malloc(sizeof(double) * (size_t) (cap > 0 ? cap : 1));
    if (si == NULL || sx == NULL) goto oom;
    s.nzmax = (size_t) (cap > 0 ? cap : 1);
    s.p = sp;
    s.i = si;
    s.x = sx;
    s.nz = NULL;
    s.packed = 1;
    s.sorted = 1;
    s.stype = 1;

    L->is_ll = h->c.final_ll ? 1 : 0;
    if (L->xtype == CHOLMOD_PATTERN) {
        /* the values allocated with exactly the space required (as cholmod_factorize) */
        if (h->c.final_pack) h->c.grow2 = 0;
    } else {
        /* a refactorization in place: what rowfac does for rows 0 .. n-1 in one call */
        L->minor = (size_t) n;
        lnz = L->nz;
        for (k = 0; k < n; k++) lnz[k] = 1;
    }
    *stopped = 0;
    for (k0 = 0; k0 < n && ok; k0 = k1) {
        if (dc_signal_caught()) {
            *stopped = 1;
            ok = 0;
            h->c.grow2 = grow2;
            break;
        }
        k1 = range_end(cnt, n, k0, target, &sum);
        /* sp[k + 1] is column k's next free place while the range is filled, its end after */
        sp[k0] = 0;
        sp[k0 + 1] = 0;
        for (k = k0 + 1; k < k1; k++) sp[k + 1] = sp[k] + cnt[k - 1];
        triu_columns(a, pinv, k0, k1, sp + 1, si, sx);
        for (k = k0; k < k1; k++) sort_column(sp[k + 1] - sp[k], si + sp[k], sx + sp[k]);
        ok = cholmod_rowfac(&s, NULL, beta, (size_t) k0, (size_t) k1, L, &h->c);
        h->c.grow2 = grow2;
        if (!ok || h->c.status < CHOLMOD_OK) {
            ok = 0;
            if (h->c.status >= CHOLMOD_OK) h->c.status = CHOLMOD_INVALID;
        } else if (h->c.status > status) {
            status = h->c.status;    /* a warning (not positive definite): kept */
        }
    }
    goto done;
oom:
    ok = 0;
    h->c.status = CHOLMOD_OUT_OF_MEMORY;
done:
    free(si);
    free(sx);
    free(sp);
    free(cnt);
    free(pinv);
    if (!ok) return 0;
    if (!h->c.final_asis
        && !cholmod_change_factor(L->xtype, L->is_ll, 0, h->c.final_pack,
                                  h->c.final_monotonic, L, &h->c))
        return 0;
    if (status > h->c.status) h->c.status = status;
    return 1;
}

/* The symbolic analysis alone (see analyse; kept for the next dc_cholmod_factor of the
 * same pattern, which then does not redo it): *entries = the entries the factor will
 * store (D and L), no numerical factorization. Returns DC_OK, DC_OUT_OF_MEMORY or
 * DC_FAILED. */
int dc_cholmod_analyse(void *handle, int n, const int *colptr, const int *rowind,
                       const double *val, int *analysed, double *entries)
{
    dc_cholmod *h = handle;
    cholmod_sparse a;
    int st;
    *entries = 0;
    csc_header(&a, n, colptr, rowind, val);
    st = analyse(h, &a, n, colptr, rowind, analysed);
    if (st == DC_OK) *entries = h->entries;
    return st;
}

/* The bytes of the numerical factor of the analysis h->L: a supernodal one's values and
 * row indices, a simplicial one's entries (D and L) at 8 + 4 bytes (0 without one). */
static double factor_bytes(const dc_cholmod *h)
{
    if (h->L == NULL) return 0.0;
    if (h->L->is_super)
        return 8.0 * (double) h->L->xsize + 4.0 * (double) h->L->ssize;
    return 12.0 * h_lnz(h->L);
}

/* The bytes the factorization that ran out of memory (DC_OUT_OF_MEMORY) was to hold,
 * need[4]: the factor; for a supernodal one its work (the largest update matrix and the
 * permuted matrix), the BLAS's buffer and the threads' stacks still to be made (0 where
 * none or unknown). */
void dc_cholmod_need(void *handle, double *need)
{
    dc_cholmod *h = handle;
    int k;
    for (k = 0; k < 4; k++) need[k] = h == NULL ? 0.0 : h->need[k];
}

/* Entries of the analysed factor (D and L; 0 without an analysis). */
double dc_cholmod_entries(void *handle)
{
    dc_cholmod *h = handle;
    return h == NULL || h->L == NULL ? 0.0 : h->entries;
}

/* Analyse (when n or the pattern changed) and factorize P A P' = L D L' for the n x n
 * CSC matrix (0-based colptr[n+1], rowind[nnz], sorted rows, values val), reading its
 * upper triangle; node blocks are ordered together when the pattern allows (*paired = their
 * size, 2 or 3, else 0; see the header). Returns DC_OK; DC_NOT_POSDEF when a pivot is zero, negative or not
 * finite (minor = its column, 0-based; the factor is kept but must not be used);
 * DC_OUT_OF_MEMORY; DC_INTERRUPTED (the stop flag set before the orderings tried, the
 * numerical factorization or a range of its rows: see the statuses above); DC_FAILED
 * (other CHOLMOD errors). *analysed = 1 when the symbolic
 * analysis was redone, *lnz = stored entries of L (unit diagonal not counted). */
int dc_cholmod_factor(void *handle, int n, const int *colptr, const int *rowind,
                      const double *val, int *analysed, long *lnz, int *minor, int *paired)
{
    dc_cholmod *h = handle;
    cholmod_sparse a;
    int j, k, ok, ranges, stopped = 0;
    const double *d;
    const int *lp;
    double held;

    *analysed = 0;
    *lnz = 0;
    *minor = -1;
    *paired = 0;
    csc_header(&a, n, colptr, rowind, val);

    {
        int st = analyse(h, &a, n, colptr, rowind, analysed);
        if (st != DC_OK) return st;
    }

    if (h->taken && !release_values(h)) {
        /* (the blocks lent to the caller were released by it before this call) */
        free_factor(h);
        return DC_FAILED;
    }
#ifdef __GLIBC__
    /* the factor is the set-up's largest allocation: the memory freed before it (the
     * assembly's, the orderings') goes back to the system first, where glibc would keep
     * what lies between blocks in use resident */
    malloc_trim(0);
#endif
    h->c.status = CHOLMOD_OK;
    h->need[0] = factor_bytes(h);
    h->need[1] = h->need[2] = h->need[3] = 0.0;
    held = h->L->xtype != CHOLMOD_PATTERN ? h->need[0] : 0.0;   /* refactorized in place */
    if (h->super) {
        /* the supernodal factorization's peak: the factor, its largest update matrix, and
         * the permuted matrix (two transposes of a, 12 bytes an entry each), and the
         * first time the BLAS's buffer and the OpenMP threads (see BLAS_BUFFER),
         * asked for first, since a failure there is not returned */
        h->need[1] = 8.0 * (double) h->L->maxcsize + 24.0 * (double) colptr[n];
        h->need[2] = blas_buffer_bytes();
        if (!omp_threads_made)
            h->need[3] = (omp_helpers() - 1) * thread_stack_bytes();
        if (!dc_room(h->need[0] + h->need[1] + h->need[2] + h->need[3] - held))
            return DC_OUT_OF_MEMORY;
    }
    if (dc_signal_caught()) return DC_INTERRUPTED;
    ranges = factor_ranges();
    if (!h->L->is_super && h->L->ordering != CHOLMOD_NATURAL && ranges > 0)
        ok = factor_by_ranges(h, &a, ranges, &stopped);
    else
        ok = cholmod_factorize(&a, h->L, &h->c);
    if (stopped) {             /* a factor made in part: not kept */
        free_factor(h);
        return DC_INTERRUPTED;
    }
    if (!ok || h->c.status < CHOLMOD_OK)
        return h->c.status == CHOLMOD_OUT_OF_MEMORY ? DC_OUT_OF_MEMORY : DC_FAILED;
    if (h->super) {
        blas_buffer_made = 1;
        omp_threads_made = 1;
    }
    if (h->L->xtype != CHOLMOD_REAL || (!h->super && (h->L->is_super || h->L->is_ll)))
        return DC_FAILED;
    if (h->c.status == CHOLMOD_NOT_POSDEF || h->L->minor < h->L->n) {
        *minor = (int) h->L->minor;
        return DC_NOT_POSDEF;
    }
    if (h->super) {
        /* LL' stops at the first pivot <= 0 (minor above). The supernodes are not relaxed
         * (no zero added): the factor has the entries of the simplicial one, L's below the
         * diagonal of each supernode's columns */
        const int *sup = h->L->super, *pi = h->L->pi;
        long cnt = 0;
        int sn;
        for (sn = 0; sn < (int) h->L->nsuper; sn++)
            for (j = sup[sn]; j < sup[sn + 1]; j++)
                cnt += pi[sn + 1] - pi[sn] - (j - sup[sn]) - 1;
        *lnz = cnt;
        *paired = h->paired;
        return DC_OK;
    }
    /* LDL' does not stop at a negative pivot: check D (first entry of each column). */
    d = h->L->x;
    lp = h->L->p;
    for (j = 0; j < n; j++) {
        double djj = d[lp[j]];
        if (!(djj > 0.0) || !isfinite(djj)) {
            *minor = j;
            return DC_NOT_POSDEF;
        }
    }
    k = 0;
    for (j = 0; j < n; j++) k += ((const int *) h->L->nz)[j] - 1;
    *lnz = k;
    *paired = h->paired;
    return DC_OK;
}

/* Stored entries of the factor's columns (diagonal included), or -1 without factors. */
long dc_cholmod_nnz(void *handle)
{
    dc_cholmod *h = handle;
    long k = 0;
    int j;
    if (h == NULL || h->L == NULL || h->L->is_super || h->taken) return -1;
    for (j = 0; j < h->n; j++) k += ((const int *) h->L->nz)[j];
    return k;
}

/* Copy the factor P A P' = L D L': perm[n] (row k of P A P' is row perm[k] of A),
 * colptr[n+1] and rowind[nnz], val[nnz] by columns, each column's first entry its
 * diagonal (D), the others L's entries below it, rows ascending (0-based throughout;
 * nnz = dc_cholmod_nnz). Returns DC_OK or DC_FAILED. */
int dc_cholmod_export(void *handle, int *perm, int *colptr, int *rowind, double *val)
{
    dc_cholmod *h = handle;
    const int *lp, *li, *lnz, *lperm;
    const double *lx;
    int j, p, k = 0;
    if (h == NULL || h->L == NULL || h->L->is_super || h->L->is_ll
        || h->L->xtype != CHOLMOD_REAL || h->taken) return DC_FAILED;
    lp = h->L->p; li = h->L->i; lnz = h->L->nz; lx = h->L->x; lperm = h->L->Perm;
    for (j = 0; j < h->n; j++) {
        perm[j] = lperm[j];
        colptr[j] = k;
        if (lnz[j] < 1 || li[lp[j]] != j) return DC_FAILED;
        for (p = lp[j]; p < lp[j] + lnz[j]; p++) {
            if (p > lp[j] && li[p] <= li[p - 1]) return DC_FAILED;
            rowind[k] = li[p];
            val[k] = lx[p];
            k++;
        }
    }
    colptr[h->n] = k;
    return DC_OK;
}

/* Whether the next analyses are for a factor that serves a few solves only (few = 1;
 * 0, the default, for one solved at every step): use_supernodal's rule for a factor
 * without node blocks. Kept in the handle for the analyses that follow. */
void dc_cholmod_few_solves(void *handle, int few)
{
    dc_cholmod *h = handle;
    if (h != NULL) h->few_solves = few != 0;
}

/* 1 when the factor is CHOLMOD's supernodal LL', 0 when simplicial LDL' (or none). */
int dc_cholmod_supernodal(void *handle)
{
    dc_cholmod *h = handle;
    return h != NULL && h->L != NULL && h->super;
}

/* The ordering of the analysis: 1 AMD, 2 METIS, 3 CHOLMOD's nested dissection (on the
 * node blocks' graph when the blocks are ordered together, else CHOLMOD's own choice), 4
 * another one of CHOLMOD's, 0 without an analysis. */
int dc_cholmod_ordering(void *handle)
{
    dc_cholmod *h = handle;
    if (h == NULL || h->L == NULL) return ORD_NONE;
    if (h->ordering != ORD_CHOLMOD) return h->ordering;
    switch (h->L->ordering) {
    case CHOLMOD_AMD: return ORD_AMD;
    case CHOLMOD_METIS: return ORD_METIS;
    case CHOLMOD_NESDIS: return ORD_NESDIS;
    default: return ORD_CHOLMOD;
    }
}

/* The BLAS that CHOLMOD's supernodal factorization (and UMFPACK's LU) calls, as text
 * copied into msg (len bytes, blank-padded for Fortran): OpenBLAS's configuration when
 * the library has one, then the file that defines dgemm_, its links resolved ("" where
 * the loader cannot tell). It is looked up as the loader resolves CHOLMOD's reference: first in the
 * process's global scope (the executable and its libraries), then among CHOLMOD's own
 * dependencies (a module loaded with dlopen, such as the Python extension). On Debian the
 * system's libblas.so.3 is an alternative: the reference BLAS or an optimized one. */
void dc_cholmod_blas(char *msg, int len)
{
    char text[1024] = "";
    void *sym = dlsym(RTLD_DEFAULT, "dgemm_");
    void *lib = NULL;
    Dl_info info;
    if (sym == NULL && dladdr((void *)cholmod_start, &info) && info.dli_fname != NULL) {
        lib = dlopen(info.dli_fname, RTLD_LAZY | RTLD_NOLOAD);
        if (lib != NULL) sym = dlsym(lib, "dgemm_");
    }
    if (sym != NULL && dladdr(sym, &info) && info.dli_fname != NULL) {
        void *own = dlopen(info.dli_fname, RTLD_LAZY | RTLD_NOLOAD);
        char *(*config)(void) = NULL;
        char *file = realpath(info.dli_fname, NULL); /* through the alternatives' links */
        const char *name = file != NULL ? file : info.dli_fname;
        if (own != NULL) {
            *(void **)(&config) = dlsym(own, "openblas_get_config");
            dlclose(own);
        }
        if (config != NULL)
            snprintf(text, sizeof text, "%s: %s", config(), name);
        else
            snprintf(text, sizeof text, "%s", name);
        free(file);
    }
    if (lib != NULL) dlclose(lib);
    int n = (int)strlen(text);
    for (int i = 0; i < len; i++) msg[i] = i < n ? text[i] : ' ';
}

/* Release the numerical values of CHOLMOD's factor (after dc_cholmod_export, when the
 * caller solves with its own copy), keeping the symbolic analysis for the next
 * factorization; cholmod_solve2 is no longer possible until then. DC_OK or DC_FAILED. */
int dc_cholmod_release_numeric(void *handle)
{
    dc_cholmod *h = handle;
    if (h == NULL || h->L == NULL) return DC_FAILED;
    free_dense(h);
    if (!release_values(h)) return DC_FAILED;
    return DC_OK;
}

/* Solve A X = B for ncol right-hand sides (b and x column-major, n x ncol) with
 * cholmod_solve2 (workspaces kept in the handle). Returns DC_OK, DC_OUT_OF_MEMORY (the
 * workspaces) or DC_FAILED. */
int dc_cholmod_solve(void *handle, int ncol, const double *b, double *x)
{
    dc_cholmod *h = handle;
    if (h == NULL || h->L == NULL || h->L->xtype != CHOLMOD_REAL || h->taken
        || (!h->super && (h->L->is_super || h->L->is_ll))) return DC_FAILED;
    if (h->B == NULL || h->bcols != ncol) {
        free_dense(h);
        h->B = calloc(1, sizeof(cholmod_dense));
        if (h->B == NULL) return DC_OUT_OF_MEMORY;
        h->bcols = ncol;
    }
    h->B->nrow = (size_t) h->n;
    h->B->ncol = (size_t) ncol;
    h->B->nzmax = (size_t) h->n * (size_t) ncol;
    h->B->d = (size_t) h->n;
    h->B->x = (void *) b;
    h->B->z = NULL;
    h->B->xtype = CHOLMOD_REAL;
    h->B->dtype = CHOLMOD_DOUBLE;
    h->c.status = CHOLMOD_OK;
    if (!cholmod_solve2(CHOLMOD_A, h->L, h->B, NULL, &h->X, NULL, &h->Y, &h->E, &h->c))
        return h->c.status == CHOLMOD_OUT_OF_MEMORY ? DC_OUT_OF_MEMORY : DC_FAILED;
    memcpy(x, h->X->x, sizeof(double) * (size_t) h->n * (size_t) ncol);
    return DC_OK;
}

/* Column j of a numeric factor: its rows, its values (first the diagonal) and their
 * number, for a simplicial LDL' factor (D on the diagonal) or a supernodal LL' one (the
 * column of its supernode from the diagonal down). col_map gives, for the supernodal
 * layout, the supernode of each column (NULL for the simplicial one). */
typedef struct {
    const int *rows;
    double *vals;
    int len;
} dc_column;

static dc_column factor_column(const cholmod_factor *L, const int *col_super, int j)
{
    dc_column c;
    if (col_super == NULL) {
        const int *lp = L->p, *lnz = L->nz;
        c.rows = (const int *) L->i + lp[j];
        c.vals = (double *) L->x + lp[j];
        c.len = lnz[j];
    } else {
        const int *sup = L->super, *pi = L->pi, *px = L->px, *ls = L->s;
        int sn = col_super[j], k = j - sup[sn], nsrow = pi[sn + 1] - pi[sn];
        c.rows = ls + pi[sn] + k;
        c.vals = (double *) L->x + px[sn] + (size_t) k * nsrow + k;
        c.len = nsrow - k;
    }
    return c;
}

/* Whether column block J (columns bs J .. bs J + bs - 1) of the factor is made of
 * bs x bs blocks: column bs J + r holds its diagonal, the rows bs J + r + 1 ..
 * bs J + bs - 1 of the diagonal block, then the same m whole blocks of bs rows as the
 * block's other columns. *m = those blocks (valid when 1 is returned). */
static int block_column(const cholmod_factor *L, const int *col_super, int bs, int J, int *m)
{
    int c0 = bs * J, r, t, k, len;
    dc_column first = factor_column(L, col_super, c0), last;
    last = factor_column(L, col_super, c0 + bs - 1);
    len = last.len - 1;
    if (len < 0 || len % bs != 0) return 0;
    *m = len / bs;
    for (r = 0; r < bs; r++) {
        dc_column c = factor_column(L, col_super, c0 + r);
        if (c.len != bs - r + len) return 0;
        for (t = 0; t < bs - r; t++)
            if (c.rows[t] != c0 + r + t) return 0;
        for (k = 0; k < len; k++) {
            int row = c.rows[bs - r + k];
            if (row != first.rows[bs + k]) return 0;
            if (k % bs == 0 ? row % bs != 0 : row != c.rows[bs - r + k - 1] + 1) return 0;
        }
    }
    return 1;
}

/* The factor turned into the layout of fortran/linalg/ldl_solves.f90's pair_ldl_t (bs = 2)
 * or triple_ldl_t (bs = 3), in place: CHOLMOD's values become the blocks' values, so
 * that one copy of the factor is held at any time. A simplicial LDL' factor's row
 * indices become the blocks' rows (the block factor then takes 8 + 4 / bs^2 bytes an
 * entry of L where CHOLMOD's took 12); a supernodal LL' factor (whose row indices are
 * one list a supernode) is turned into LDL' on the way (l_ij / l_jj below the diagonal,
 * D = l_jj^2) and its blocks' rows are a new array. The caller's arrays (1-based, as in
 * ldl_solves): perm[n], bp[n / bs + 1] (the first block of each block column), d[n] (D),
 * ld[n / 2] (pairs: l21 of each diagonal block) or ld[3 n / 3] (triples: l21, l31, l32
 * of each). *bx = the blocks' values (pairs: 4 a block, l11, l21, l12, l22; triples: 9
 * a block by columns, then one zero block), *bi = each block's row (pairs: its first row,
 * odd; triples: its triple), *nb = the blocks. The arrays *bx and *bi stay owned by the
 * handle: they are valid until the next dc_cholmod_factor, dc_cholmod_release_numeric or
 * dc_cholmod_free. DC_FAILED (and the factor untouched) when the factor is not made of
 * such blocks or not stored in column order. */
int dc_cholmod_take_blocks(void *handle, int bs, int *perm, int *bp, double *d, double *ld,
                           long *nb, double **bx, int **bi)
{
    dc_cholmod *h = handle;
    cholmod_factor *L;
    const int *lperm;
    int *col_super = NULL, *nbi = NULL;
    double *lx, *tmp = NULL, *nx, scale[3];
    int *ni;
    int n, nn, J, m, mmax = 0, r, t, k, super;
    long q = 0, need, avail;
    size_t nsize;
    *nb = 0;
    *bx = NULL;
    *bi = NULL;
    if (h == NULL || h->L == NULL || h->taken || (bs != 2 && bs != 3)) return DC_FAILED;
    L = h->L;
    super = L->is_super;
    if (L->xtype != CHOLMOD_REAL || (super ? !L->is_ll : (L->is_ll || !L->is_monotonic)))
        return DC_FAILED;
    n = (int) L->n;
    if (n < bs || n % bs != 0) return DC_FAILED;
    nn = n / bs;
    lperm = L->Perm;
    if (super) {
        const int *sup = L->super, *px = L->px;
        int sn;
        col_super = malloc(sizeof(int) * (size_t) n);
        if (col_super == NULL) return DC_FAILED;
        for (sn = 0; sn < (int) L->nsuper; sn++) {
            if (sn > 0 && px[sn] < px[sn - 1]) goto fail;
            for (k = sup[sn]; k < sup[sn + 1]; k++) col_super[k] = sn;
        }
        avail = (long) L->xsize;
    } else {
        const int *lp = L->p, *lnz = L->nz;
        for (k = 1; k < n; k++)
            if (lp[k] < lp[k - 1] + lnz[k - 1]) return DC_FAILED;
        avail = (long) lp[n - 1] + lnz[n - 1];
    }
    /* check the layout (nothing changed yet) and count the blocks */
    for (J = 0; J < nn; J++) {
        if (!block_column(L, col_super, bs, J, &m)) goto fail;
        q += m;
        if (m > mmax) mmax = m;
    }
    /* room for the blocks (and the triples' zero block) in CHOLMOD's values: L holds
     * bs (bs - 1) / 2 + bs entries more than the blocks for each block column */
    need = (long) bs * bs * q + (bs == 3 ? 9 : 0);
    if (need > avail) goto fail;
    tmp = malloc(sizeof(double) * (size_t) (bs * bs * (mmax > 0 ? mmax : 1)));
    if (super) nbi = malloc(sizeof(int) * (size_t) (q > 0 ? q : 1));
    if (tmp == NULL || (super && nbi == NULL)) goto fail;
    for (k = 0; k < n; k++) perm[k] = lperm[k] + 1;
    /* move each block column's blocks down to their place, in column order: the place
     * of block column J starts at or before CHOLMOD's column bs J, and ends before the
     * next one's, so that no value is overwritten before it is read */
    lx = L->x;
    q = 0;
    for (J = 0; J < nn; J++) {
        int c0 = bs * J;
        dc_column c[3];
        int *rows_out;
        for (r = 0; r < bs; r++) c[r] = factor_column(L, col_super, c0 + r);
        m = (c[bs - 1].len - 1) / bs;
        bp[J] = (int) q + 1;
        /* LDL' of the column: D and the scale of L's entries (1 when already LDL') */
        for (r = 0; r < bs; r++) {
            double v = c[r].vals[0];
            d[c0 + r] = super ? v * v : v;
            scale[r] = super ? 1.0 / v : 1.0;
        }
        if (bs == 2) {
            ld[J] = c[0].vals[1] * scale[0];
        } else {
            ld[3 * J] = c[0].vals[1] * scale[0];
            ld[3 * J + 1] = c[0].vals[2] * scale[0];
            ld[3 * J + 2] = c[1].vals[1] * scale[1];
        }
        for (k = 0; k < m; k++)
            for (r = 0; r < bs; r++)        /* column r of block k */
                for (t = 0; t < bs; t++)    /* its row t */
                    tmp[bs * bs * k + bs * r + t] = c[r].vals[bs - r + bs * k + t] * scale[r];
        rows_out = super ? nbi : (int *) L->i;
        for (k = 0; k < m; k++) {
            int row = c[0].rows[bs + bs * k];
            rows_out[q + k] = bs == 2 ? row + 1 : row / 3 + 1;
        }
        memcpy(lx + (size_t) bs * bs * q, tmp, sizeof(double) * (size_t) (bs * bs * m));
        q += m;
    }
    free(tmp);
    free(col_super);
    if (bs == 3)
        for (k = 0; k < 9; k++) lx[9 * q + k] = 0.0;
    bp[nn] = (int) q + 1;
    /* give the tails back (CHOLMOD's allocator; its count of the bytes in use is then
     * off by the tails, which matters to nothing here) */
    nsize = super ? L->xsize : L->nzmax;
    nx = cholmod_realloc((size_t) (need > 0 ? need : 1), sizeof(double), lx, &nsize, &h->c);
    if (nx != NULL) L->x = nx;
    if (super) {
        h->bi = nbi;
    } else {
        nsize = L->nzmax;
        ni = cholmod_realloc((size_t) (q > 0 ? q : 1), sizeof(int), L->i, &nsize, &h->c);
        if (ni != NULL) L->i = ni;
    }
    free_dense(h);
    h->taken = 1;
    *nb = q;
    *bx = L->x;
    *bi = super ? h->bi : (int *) L->i;
    return DC_OK;
fail:
    free(tmp);
    free(col_super);
    free(nbi);
    return DC_FAILED;
}
