!> Triangular solves with LDL^T factors in the layout of 2x2 (3x3) node blocks: turned so
!> in place from CHOLMOD's factor (cholmod_shim.c's dc_cholmod_take_blocks; the blocks'
!> rows and values then stay CHOLMOD's memory, `borrowed`), or copied from its columns
!> (dc_cholmod_export, then pair_ldl_build / triple_ldl_build).
!>
!> When the matrix is made of the 2x2 blocks of node pairs and the ordering keeps each
!> pair together (the shim does so), L is made of 2x2 blocks too: block column J (dofs
!> 2J-1, 2J of the permuted matrix) has a unit lower diagonal block [1 0; l21 1] and
!> full 2x2 blocks below it. Stored by blocks (one row index for four entries, the
!> entries of a block adjacent), the forward and backward sweeps treat a block's two
!> rows as one 2-vector, which the compiler packs into SIMD multiplies and adds: about
!> 1.4x faster than cholmod_solve2 on the same factor (docs/performance.md, "The
!> solves"), which chases one row index per entry. The results differ from
!> cholmod_solve2's by round-off (another order of the same products).
!>
!> In 3D the nodes' three dofs are ordered together in the same way, and L is made of 3x3
!> blocks: triple_ldl_t, with the same sweeps. There the work vector is stored by nodes
!> padded to four entries, and a block's column is read as four adjacent entries (its
!> three and the next one), so that a block's rows are updated as one 4-vector: one
!> 256-bit multiply and add a column with AVX, where 3-vectors were compiled to scalar
!> operations. The fourth lane carries a throw-away value that never meets the other
!> three (lanes are independent) and is reset at each solve; the blocks stay 9 entries
!> (columns padded to four in memory took a third more memory and were no faster,
!> docs/performance.md).
module ldl_solves
    use iso_c_binding, only: c_int, c_ptr, c_funptr, c_loc, c_funloc, c_f_pointer
    use kinds, only: dp, i8
    use text, only: env_text
    implicit none
    private

    !> LDL^T factors by 2x2 blocks of node pairs.
    type, public :: pair_ldl_t
        integer :: n = 0                          !! matrix size (even; 0: no factors)
        integer :: nn = 0                         !! node pairs (n/2)
        integer, allocatable :: perm(:)           !! (n) row k of P A P^T is row perm(k) of A
        integer, allocatable :: bp(:)             !! (nn + 1) blocks of each block column
        integer, pointer, contiguous :: bi(:) => null()     !! (n_blocks) first row of the block (odd)
        real(dp), pointer, contiguous :: bx(:, :) => null() !! (4, n_blocks) l11, l21, l12, l22
        logical :: borrowed = .false.             !! bi, bx are CHOLMOD's memory (not freed here)
        real(dp), allocatable :: l21(:)           !! (nn) L's entry in each diagonal block
        real(dp), allocatable :: d(:)             !! (n) D
        real(dp), allocatable :: y(:)             !! (n) work vector of the solves
        integer :: sa = -1                        !! two-thread split: block columns cols(1:sa) and
                                                  !! cols(sa+1:ss-1) have no L entries between them
                                                  !! (-1: not yet looked for; 0: none)
        integer :: ss = 0                         !! first block column of the separator (ss..nn, after both)
        integer, allocatable :: cols(:)           !! (nn) the two groups' block columns, each ascending, then ss..nn
        real(dp), allocatable :: ys(:, :)         !! (n - 2 ss + 2, 2) each subtree's updates of the separator's rows
        integer :: asked = 0                      !! &solver threads: 0 automatic, 1, 2
        integer :: threads = 0                    !! threads of the solves (1, 2; 0: not decided)
        integer :: par_min_n = 0                  !! smallest n solved on two threads (with threads)
    end type pair_ldl_t

    !> LDL^T factors by 3x3 blocks of node triples.
    type, public :: triple_ldl_t
        integer :: n = 0                          !! matrix size (a multiple of 3; 0: no factors)
        integer :: nt = 0                         !! node triples (n/3)
        integer, allocatable :: perm(:)           !! (n) row k of P A P^T is row perm(k) of A
        integer, allocatable :: bp(:)             !! (nt + 1) blocks of each block column
        integer, pointer, contiguous :: bi(:) => null()     !! (n_blocks) block row (triple I: rows 3I-2 .. 3I)
        real(dp), pointer, contiguous :: bx(:, :) => null() !! (9, n_blocks + 1) by columns: l11,
                                                            !! l21, l31, l12, ..., l33; a last zero block (the
                                                            !! fourth lane's read)
        logical :: borrowed = .false.             !! bi, bx are CHOLMOD's memory (not freed here)
        real(dp), allocatable :: ld(:, :)         !! (3, nt) L's entries l21, l31, l32 in each diagonal block
        real(dp), allocatable :: d(:)             !! (n) D
        real(dp), allocatable :: y(:, :)          !! (4, nt) work vector of the solves, by triples
        integer :: sa = -1                        !! two-thread split (as pair_ldl_t's, by triples)
        integer :: ss = 0                         !! first block column of the separator
        integer, allocatable :: cols(:)           !! (nt) the two groups' block columns, then ss..nt
        real(dp), allocatable :: ys(:, :, :)      !! (4, nt - ss + 1, 2) updates of the separator

        integer :: asked = 0                      !! the threads setting: 0 automatic, 1, 2
        integer :: threads = 0                    !! threads of the solves (1, 2; 0: not decided)
        integer :: par_min_n = 0                  !! smallest n solved on two threads (with threads)
    end type triple_ldl_t

    public :: pair_ldl_build, pair_ldl_solve, pair_ldl_solve_many, pair_ldl_free
    public :: triple_ldl_build, triple_ldl_solve, triple_ldl_solve_many, triple_ldl_free
    public :: ldl_threads_set, ldl_threads_env, ldl_threads_choice, ldl_cpus, pair_ldl_threads, &
              triple_ldl_threads

    !> Force the threads of a factor's solves (tests compare both paths).
    interface ldl_threads_set
        module procedure pair_threads_set, triple_threads_set
    end interface ldl_threads_set

    !> Two threads in the 2x2 block solves (pair_ldl_solve) from this many dofs: below it
    !> the forking costs more than the half sweep saves (docs/performance.md, "Two
    !> threads in the triangular solve").
    integer, parameter, public :: PAR_MIN_DOFS = 20000

    interface
        !> 1 when this process may use the helper thread (two_threads.c: not a fork of a
        !> process that had started one).
        function dc_two_usable() bind(C, name='dc_two_usable') result(ok)
            import :: c_int
            integer(c_int) :: ok
        end function dc_two_usable
        !> fn(ctx, 1) here and fn(ctx, 2) on the helper thread if it takes it before
        !> item 1 is done, else here too (two_threads.c); 2 when the helper ran it.
        function dc_two_items(fn, ctx) bind(C, name='dc_two_items') result(by)
            import :: c_int, c_ptr, c_funptr
            type(c_funptr), value :: fn  !! work item: fn(ctx, item)
            type(c_ptr), value :: ctx    !! its data
            integer(c_int) :: by
        end function dc_two_items
    end interface

    !> One two-thread solve's data for the work items (pair_item, triple_item): the
    !> factors, b, x and the sweep (1 forward, 2 backward).
    type :: two_job_t
        type(pair_ldl_t), pointer :: pf => null()     !! 2x2 factors, or
        type(triple_ldl_t), pointer :: tf => null()   !! 3x3 factors
        real(dp), pointer :: b(:) => null()           !! right-hand side
        real(dp), pointer :: x(:) => null()           !! solution
        integer :: sweep = 1                          !! 1 forward, 2 backward
    end type two_job_t

contains

    !> The block copy of the factor P A P^T = L D L^T given by columns (0-based perm,
    !> colptr, rowind as dc_cholmod_export gives them; each column's first entry its
    !> diagonal D, then L's entries below it, rows ascending). ok = .false. (and f
    !> empty) when L is not made of 2x2 blocks of the pairs (2J-1, 2J).
    pure subroutine pair_ldl_build(f, n, perm, colptr, rowind, val, ok)
        type(pair_ldl_t), intent(inout) :: f                !! block factors (replaced)
        integer, intent(in) :: n                            !! size
        integer, intent(in) :: perm(:)                      !! (n) 0-based permutation
        integer, intent(in) :: colptr(:)                    !! (n + 1) 0-based column starts
        integer, intent(in) :: rowind(:)                    !! 0-based rows
        real(dp), intent(in) :: val(:)                      !! D and L by columns
        logical, intent(out) :: ok                          !! L is made of 2x2 blocks
        integer :: jb, c0, c1, p0, p1, e0, e1, nb, i
        call pair_ldl_free(f)
        ok = .false.
        if (n < 2 .or. mod(n, 2) /= 0) return
        f%nn = n / 2
        allocate (f%perm(n), f%bp(f%nn + 1), f%l21(f%nn), f%d(n), f%y(n))
        ! count the blocks and check the structure
        nb = 0
        do jb = 1, f%nn
            c0 = 2 * jb - 1
            c1 = 2 * jb
            p0 = colptr(c0) + 1; e0 = colptr(c0 + 1)
            p1 = colptr(c1) + 1; e1 = colptr(c1 + 1)
            ! column c0: diagonal, then row c1, then the pairs; column c1: diagonal, pairs
            if (e0 - p0 + 1 < 2 .or. e0 - p0 /= e1 - p1 + 1) return
            if (rowind(p0) + 1 /= c0 .or. rowind(p0 + 1) + 1 /= c1 .or. rowind(p1) + 1 /= c1) return
            do i = 0, (e1 - p1) / 2 - 1
                if (mod(rowind(p0 + 2 + 2 * i), 2) /= 0) return
                if (rowind(p0 + 3 + 2 * i) /= rowind(p0 + 2 + 2 * i) + 1) return
                if (rowind(p1 + 1 + 2 * i) /= rowind(p0 + 2 + 2 * i)) return
                if (rowind(p1 + 2 + 2 * i) /= rowind(p0 + 3 + 2 * i)) return
            end do
            if (mod(e1 - p1, 2) /= 0) return
            nb = nb + (e1 - p1) / 2
        end do
        allocate (f%bi(nb), f%bx(4, nb))
        nb = 0
        do jb = 1, f%nn
            c0 = 2 * jb - 1
            c1 = 2 * jb
            p0 = colptr(c0) + 1
            p1 = colptr(c1) + 1
            f%bp(jb) = nb + 1
            f%d(c0) = val(p0)
            f%d(c1) = val(p1)
            f%l21(jb) = val(p0 + 1)
            do i = 0, (colptr(c1 + 1) - p1) / 2 - 1
                nb = nb + 1
                f%bi(nb) = rowind(p0 + 2 + 2 * i) + 1
                f%bx(:, nb) = [val(p0 + 2 + 2 * i), val(p0 + 3 + 2 * i), &
                               val(p1 + 1 + 2 * i), val(p1 + 2 + 2 * i)]
            end do
        end do
        f%bp(f%nn + 1) = nb + 1
        f%perm = perm(1:n) + 1
        f%n = n
        ok = .true.
    end subroutine pair_ldl_build

    !> x = A^{-1} b with the block factors (b and x: n entries; they may not alias). On
    !> two threads (pair_sweeps_two) when pair_ldl_threads chose two (decided at the
    !> first solve unless it was called before, or ldl_threads_set forced a count), the
    !> factor has n >= the threshold dofs and its elimination tree splits below a
    !> separator (find_split); else pair_sweeps.
    subroutine pair_ldl_solve(f, b, x)
        type(pair_ldl_t), intent(inout) :: f                !! block factors (work vector used)
        real(dp), intent(in) :: b(:)                        !! right-hand side (n)
        real(dp), intent(out) :: x(:)                       !! solution (n)
        integer :: used
        if (f%threads == 0) call pair_ldl_threads(f, f%asked, used)
        if (f%threads >= 2 .and. f%n >= f%par_min_n .and. dc_two_usable() /= 0) then
            if (f%sa < 0) call pair_find_split(f)
            if (f%sa > 0) then
                call pair_sweeps_two(f, b, x)
                return
            end if
        end if
        call pair_sweeps(f%n, f%nn, size(f%bi), f%perm, f%bp, f%bi, f%bx, f%l21, f%d, b, x, f%y)
    end subroutine pair_ldl_solve

    !> Decide the threads of a factor's solves from the setting `asked` (&solver threads:
    !> 0 automatic, 1, 2), DYNCONTACT_THREADS, the CPUs the process may use (ldl_cpus)
    !> and the factor's size (ldl_threads_choice); with two, look for the split of the
    !> elimination tree, and fall back to one when there is none, or when this process
    !> is a fork of one that had started the helper thread (two_threads.c). `used`: the
    !> threads its solves use from now on (1 or 2). Called again after a new
    !> factorization, it decides again.
    subroutine pair_ldl_threads(f, asked, used)
        type(pair_ldl_t), intent(inout) :: f                !! block factors (n > 0)
        integer, intent(in) :: asked                        !! 0 (automatic), 1 or 2
        integer, intent(out) :: used                        !! threads of the solves
        f%asked = max(0, min(2, asked))
        call threads_wanted(f%asked, f%n, f%threads, f%par_min_n)
        if (f%threads >= 2 .and. f%sa < 0) call pair_find_split(f)
        if (f%sa <= 0) f%threads = 1
        used = f%threads
    end subroutine pair_ldl_threads

    !> pair_ldl_threads for the 3x3 block factors.
    subroutine triple_ldl_threads(f, asked, used)
        type(triple_ldl_t), intent(inout) :: f              !! block factors (n > 0)
        integer, intent(in) :: asked                        !! 0 (automatic), 1 or 2
        integer, intent(out) :: used                        !! threads of the solves
        f%asked = max(0, min(2, asked))
        call threads_wanted(f%asked, f%n, f%threads, f%par_min_n)
        if (f%threads >= 2 .and. f%sa < 0) call triple_find_split(f)
        if (f%sa <= 0) f%threads = 1
        used = f%threads
    end subroutine triple_ldl_threads

    !> The threads ldl_threads_choice gives a factor of n dofs in this process and the
    !> size from which two are used (the environment's, else PAR_MIN_DOFS); 1 in a fork
    !> of a process that had started the helper thread (two_threads.c).
    subroutine threads_wanted(asked, n, threads, min_dofs)
        integer, intent(in) :: asked                        !! 0, 1 or 2
        integer, intent(in) :: n                            !! dofs of the factor
        integer, intent(out) :: threads                     !! 1 or 2
        integer, intent(out) :: min_dofs                    !! smallest n solved on two threads
        integer :: env
        call ldl_threads_env(env, min_dofs)
        threads = ldl_threads_choice(asked, env, ldl_cpus(), n, min_dofs)
        if (dc_two_usable() == 0) threads = 1
    end subroutine threads_wanted

    !> The threads of the triangular solves of a factor of n dofs: `env` (the
    !> environment's DYNCONTACT_THREADS, 1 or 2; 0 when not set) overrides `asked` (the
    !> scene's &solver threads: 0 automatic, 1, 2); 2 asked gives two threads from
    !> min_dofs dofs; automatic gives two when the process may run on two CPUs or more
    !> (cpus, ldl_cpus) and n >= min_dofs. Anything else: one.
    pure integer function ldl_threads_choice(asked, env, cpus, n, min_dofs) result(threads)
        integer, intent(in) :: asked                        !! 0, 1 or 2 (the scene)
        integer, intent(in) :: env                          !! 0 (not set), 1 or 2
        integer, intent(in) :: cpus                         !! CPUs the process may use
        integer, intent(in) :: n                            !! dofs of the factor
        integer, intent(in) :: min_dofs                     !! smallest n solved on two threads
        integer :: want
        want = asked
        if (env == 1 .or. env == 2) want = env
        threads = 1
        if (n < min_dofs) return
        if (want == 2 .or. (want == 0 .and. cpus >= 2)) threads = 2
    end function ldl_threads_choice

    !> The CPUs this process may run on, as OpenMP sees them: omp_get_num_procs (the
    !> CPUs of the process's affinity mask, sched_getaffinity, in libgomp), limited by
    !> omp_get_max_threads (OMP_NUM_THREADS, when set); 1 without OpenMP.
    integer function ldl_cpus() result(cpus)
        !$ use omp_lib, only: omp_get_num_procs, omp_get_max_threads
        cpus = 1
        !$ cpus = max(1, min(omp_get_num_procs(), omp_get_max_threads()))
    end function ldl_cpus

    !> DYNCONTACT_THREADS (1: one thread, 2: two; anything else, or not set: 0) and the
    !> test-only DYNCONTACT_THREADS_MIN_DOFS (the size from which two threads are used;
    !> default PAR_MIN_DOFS).
    subroutine ldl_threads_env(threads, min_dofs)
        integer, intent(out) :: threads                     !! 0, 1 or 2
        integer, intent(out) :: min_dofs                    !! smallest n solved on two threads
        character(len=:), allocatable :: v
        integer :: ios, m
        threads = 0
        min_dofs = PAR_MIN_DOFS
        v = env_text('DYNCONTACT_THREADS')
        if (v == '1') threads = 1
        if (v == '2') threads = 2
        v = env_text('DYNCONTACT_THREADS_MIN_DOFS')
        if (len(v) > 0) then
            read (v, *, iostat=ios) m
            if (ios == 0 .and. m >= 0) min_dofs = m
        end if
    end subroutine ldl_threads_env

    !> Force the threads of a factor's solves (1 or 2, whatever the setting and the
    !> environment; 0: decide again at the next solve) and the size from which two are
    !> used (tests compare both paths).
    pure subroutine pair_threads_set(f, threads, min_dofs)
        type(pair_ldl_t), intent(inout) :: f                !! block factors
        integer, intent(in) :: threads                      !! 0, 1 or 2
        integer, intent(in) :: min_dofs                     !! smallest n solved on two threads
        f%threads = max(0, min(2, threads))
        f%par_min_n = max(0, min_dofs)
    end subroutine pair_threads_set

    !> pair_threads_set for the 3x3 block factors.
    pure subroutine triple_threads_set(f, threads, min_dofs)
        type(triple_ldl_t), intent(inout) :: f              !! block factors
        integer, intent(in) :: threads                      !! 0, 1 or 2
        integer, intent(in) :: min_dofs                     !! smallest n solved on two threads
        f%threads = max(0, min(2, threads))
        f%par_min_n = max(0, min_dofs)
    end subroutine triple_threads_set

    !> The split of the triples' elimination tree (find_split on the block rows) and the
    !> separator buffers.
    pure subroutine triple_find_split(f)
        type(triple_ldl_t), intent(inout) :: f              !! block factors
        call find_split(f%nt, f%bp, f%bi, f%sa, f%ss, f%cols)
        if (allocated(f%ys)) deallocate (f%ys)
        if (f%sa > 0) allocate (f%ys(4, max(1, f%nt - f%ss + 1), 2))
    end subroutine triple_find_split

    !> The split of the pairs' elimination tree (find_split on the block rows) and the
    !> separator buffers.
    pure subroutine pair_find_split(f)
        type(pair_ldl_t), intent(inout) :: f                !! block factors
        integer, allocatable :: brow(:)
        allocate (brow(size(f%bi)))
        brow = (f%bi + 1) / 2
        call find_split(f%nn, f%bp, brow, f%sa, f%ss, f%cols)
        if (allocated(f%ys)) deallocate (f%ys)
        if (f%sa > 0) allocate (f%ys(max(1, f%n - 2 * f%ss + 2), 2))
    end subroutine pair_find_split

    !> A split of the block columns 1..nblk of L for two threads: cols(1:na) and
    !> cols(na+1:ss-1) (each ascending; together 1..ss-1) with no L entry of the one in
    !> the rows of the other, and ss..nblk, the separator, after both; na = 0 when there
    !> is none. From the elimination tree (parent: the first block row below the diagonal
    !> of each column; the roots children of a virtual root nblk + 1): walk down from the
    !> root while each node has one child (those nodes, the last columns since each is
    !> the parent of all the others, are the separator), then share the first node with
    !> two children or more's children, with their subtrees, between two groups of about
    !> equal blocks (each child to the lighter group so far). L's rows in a column are
    !> ancestors of it, so two subtrees touch only the separator; this is checked on the
    !> blocks (na = 0 if not). The ordering need not be postordered (the shim's is not:
    !> it keeps the node blocks in place), hence lists of columns, not ranges.
    pure subroutine find_split(nblk, bp, brow, na, ss, cols)
        integer, intent(in) :: nblk                         !! block columns
        integer, intent(in) :: bp(nblk + 1)                 !! blocks of each block column
        integer, intent(in) :: brow(:)                      !! block row of each block
        integer, intent(out) :: na                          !! columns of the first group
        integer, intent(out) :: ss                          !! first column of the separator
        integer, allocatable, intent(out) :: cols(:)        !! (nblk) the two groups' columns, then ss..nblk
        integer, allocatable :: parent(:), nch(:), child(:), top(:), grp(:)
        integer(i8), allocatable :: work(:)
        integer :: j, q, r, nb
        integer(i8) :: wg(2)
        na = 0
        ss = nblk + 1
        allocate (cols(0))
        if (nblk < 4) return
        allocate (parent(nblk), nch(nblk + 1), child(nblk + 1), top(nblk), work(nblk + 1), &
                  grp(nblk))
        nch = 0
        do j = 1, nblk
            parent(j) = nblk + 1
            do q = bp(j), bp(j + 1) - 1
                parent(j) = min(parent(j), brow(q))
            end do
            if (parent(j) <= j) return       ! not lower triangular by blocks
            nch(parent(j)) = nch(parent(j)) + 1
            child(parent(j)) = j
        end do
        r = nblk + 1
        do while (nch(r) == 1)
            r = child(r)
        end do
        if (nch(r) < 2) return               ! a path: no two subtrees
        ss = r
        ! top(j): the child of r whose subtree holds j; the subtrees' blocks
        work = 0
        do j = ss - 1, 1, -1
            if (parent(j) == r) then
                top(j) = j
            else if (parent(j) >= ss) then
                ss = nblk + 1                ! not below r: no split
                return
            else
                top(j) = top(parent(j))
            end if
            work(top(j)) = work(top(j)) + (bp(j + 1) - bp(j)) + 1
        end do
        wg = 0
        do j = 1, ss - 1
            if (top(j) /= j) cycle
            grp(j) = merge(1, 2, wg(1) <= wg(2))
            wg(grp(j)) = wg(grp(j)) + work(j)
        end do
        do j = 1, ss - 1
            grp(j) = grp(top(j))
        end do
        ! the check: a column's rows in its own group or the separator
        do j = 1, ss - 1
            do q = bp(j), bp(j + 1) - 1
                if (brow(q) < ss) then
                    if (grp(brow(q)) /= grp(j)) then
                        ss = nblk + 1
                        return
                    end if
                end if
            end do
        end do
        deallocate (cols)
        allocate (cols(nblk))
        nb = 0
        do q = 1, 2
            do j = 1, ss - 1
                if (grp(j) /= q) cycle
                nb = nb + 1
                cols(nb) = j
            end do
            if (q == 1) na = nb
        end do
        cols(ss:nblk) = [(j, j = ss, nblk)]
        if (na == 0 .or. na == ss - 1) then
            na = 0
            ss = nblk + 1
        end if
    end subroutine find_split

    !> pair_sweeps on two threads with the split of find_split (the calling thread and
    !> two_threads.c's helper, when it is free in time; else the calling thread alone,
    !> the same operations): the forward sweep of the two ranges at once, each adding
    !> its updates of the separator's rows into a buffer of its own (zeroed), the
    !> separator's rows then b + first's + second's
    !> (always this order: the same result run to run); the separator forward and back;
    !> then the backward sweep of the two ranges at once (they read the separator's
    !> rows, final). The operations are those of pair_sweeps but for the separator's
    !> sums, added in another order: the results differ by round-off.
    subroutine pair_sweeps_two(f, b, x)
        type(pair_ldl_t), target, intent(inout) :: f        !! block factors (split found)
        real(dp), target, intent(in) :: b(:)                !! right-hand side (n)
        real(dp), target, intent(out) :: x(:)               !! solution (n)
        type(two_job_t), target :: job
        integer :: rs, nb, i, by
        real(dp) :: none(2)
        rs = 2 * f%ss - 1
        nb = size(f%bi)
        job%pf => f
        job%b => b
        job%x => x
        job%sweep = 1
        by = dc_two_items(c_funloc(pair_item), c_loc(job))
        do i = rs, f%n
            f%y(i) = (b(f%perm(i)) + f%ys(i - rs + 1, 1)) + f%ys(i - rs + 1, 2)
        end do
        call pair_fwd(f%n, f%nn, nb, f%bp, f%bi, f%bx, f%l21, f%d, f%nn - f%ss + 1, &
                      f%cols(f%ss:f%nn), f%n + 1, f%y, 2, none)
        call pair_bwd(f%n, f%nn, nb, f%perm, f%bp, f%bi, f%bx, f%l21, f%nn - f%ss + 1, &
                      f%cols(f%ss:f%nn), f%y, x)
        job%sweep = 2
        by = dc_two_items(c_funloc(pair_item), c_loc(job))
    end subroutine pair_sweeps_two

    !> Work item `item` (1: the first group, cols(1:sa); 2: the second) of the sweep
    !> job%sweep of pair_sweeps_two: forward, P b gathered into the group's rows, its
    !> updates of the separator's rows into ys(:, item) (zeroed first); backward.
    subroutine pair_item(ctx, item) bind(C)
        type(c_ptr), value :: ctx                           !! the two_job_t
        integer(c_int), value :: item                       !! 1 or 2
        type(two_job_t), pointer :: job
        integer :: t0, t1, t, jb
        call c_f_pointer(ctx, job)
        associate (f => job%pf)
            t0 = merge(1, f%sa + 1, item == 1)
            t1 = merge(f%sa, f%ss - 1, item == 1)
            if (job%sweep == 1) then
                do t = t0, t1
                    jb = f%cols(t)
                    f%y(2 * jb - 1) = job%b(f%perm(2 * jb - 1))
                    f%y(2 * jb) = job%b(f%perm(2 * jb))
                end do
                f%ys(:, item) = 0.0_dp
                call pair_fwd(f%n, f%nn, size(f%bi), f%bp, f%bi, f%bx, f%l21, f%d, t1 - t0 + 1, &
                              f%cols(t0:t1), 2 * f%ss - 1, f%y, size(f%ys, 1), f%ys(:, item))
            else
                call pair_bwd(f%n, f%nn, size(f%bi), f%perm, f%bp, f%bi, f%bx, f%l21, &
                              t1 - t0 + 1, f%cols(t0:t1), f%y, job%x)
            end if
        end associate
    end subroutine pair_item

    !> The forward sweep of pair_sweeps on the block columns cl (ascending; y's rows
    !> gathered): updates of rows >= rs go into ys (row rs: ys(1)), the others into y.
    pure subroutine pair_fwd(n, nn, nb, bp, bi, bx, l21, d, nc, cl, rs, y, ns, ys)
        integer, intent(in) :: n, nn, nb                    !! size, pairs, blocks
        integer, intent(in) :: bp(nn + 1), bi(nb)           !! block structure
        real(dp), intent(in) :: bx(4, nb), l21(nn), d(n)    !! L's blocks, diagonal blocks, D
        integer, intent(in) :: nc                           !! block columns
        integer, intent(in) :: cl(nc)                       !! their indices, ascending
        integer, intent(in) :: rs                           !! first row kept in ys
        real(dp), intent(inout) :: y(n)                     !! work
        integer, intent(in) :: ns                           !! size of ys
        real(dp), intent(inout) :: ys(ns)                   !! updates of rows >= rs
        real(dp) :: y0, y1
        integer :: t, jb, q, i, k
        do t = 1, nc
            jb = cl(t)
            y0 = y(2 * jb - 1)
            y1 = y(2 * jb) - l21(jb) * y0
            do q = bp(jb), bp(jb + 1) - 1
                i = bi(q)
                if (i < rs) then
                    y(i:i + 1) = y(i:i + 1) - (bx(1:2, q) * y0 + bx(3:4, q) * y1)
                else
                    k = i - rs + 1
                    ys(k:k + 1) = ys(k:k + 1) - (bx(1:2, q) * y0 + bx(3:4, q) * y1)
                end if
            end do
            y(2 * jb - 1) = y0 / d(2 * jb - 1)
            y(2 * jb) = y1 / d(2 * jb)
        end do
    end subroutine pair_fwd

    !> The backward sweep of pair_sweeps on the block columns cl, last first (the rows
    !> below them final), each pair stored into x = P^T z.
    pure subroutine pair_bwd(n, nn, nb, perm, bp, bi, bx, l21, nc, cl, y, x)
        integer, intent(in) :: n, nn, nb                    !! size, pairs, blocks
        integer, intent(in) :: perm(n), bp(nn + 1), bi(nb)  !! permutation, block structure
        real(dp), intent(in) :: bx(4, nb), l21(nn)          !! L's blocks, diagonal blocks
        integer, intent(in) :: nc                           !! block columns
        integer, intent(in) :: cl(nc)                       !! their indices, ascending
        real(dp), intent(inout) :: y(n)                     !! work
        real(dp), intent(inout) :: x(n)                     !! solution (the pairs cl set)
        real(dp) :: y0, y1, s(4)
        integer :: t, jb, q, i
        do t = nc, 1, -1
            jb = cl(t)
            s = 0.0_dp
            do q = bp(jb), bp(jb + 1) - 1
                i = bi(q)
                s(1:2) = s(1:2) + bx(1:2, q) * y(i:i + 1)
                s(3:4) = s(3:4) + bx(3:4, q) * y(i:i + 1)
            end do
            y1 = y(2 * jb) - (s(3) + s(4))
            y0 = y(2 * jb - 1) - (s(1) + s(2)) - l21(jb) * y1
            y(2 * jb) = y1
            y(2 * jb - 1) = y0
            x(perm(2 * jb)) = y1
            x(perm(2 * jb - 1)) = y0
        end do
    end subroutine pair_bwd

    !> X = A^{-1} B for the k columns of B with one pass over the factor for all of them
    !> (the factor is read once per k columns instead of once per column: the solves of
    !> many right-hand sides are bound by reading L). Each column gets the operations of
    !> pair_ldl_solve in the same order.
    pure subroutine pair_ldl_solve_many(f, b, x, ok)
        type(pair_ldl_t), intent(in) :: f                   !! block factors
        real(dp), intent(in) :: b(:, :)                     !! right-hand sides (n, k)
        real(dp), intent(out) :: x(:, :)                    !! solutions (n, k)
        logical, intent(out) :: ok                          !! .false.: out of memory (x not set)
        real(dp), allocatable :: y(:, :)
        integer :: ist
        allocate (y(size(b, 2), f%n), stat=ist)
        ok = ist == 0
        if (.not. ok) return
        call pair_sweeps_many(f%n, f%nn, size(f%bi), size(b, 2), f%perm, f%bp, f%bi, f%bx, &
                              f%l21, f%d, b, x, y)
    end subroutine pair_ldl_solve_many

    !> pair_sweeps for k right-hand sides, the work array by rows (y(:, i): row i of the
    !> k columns, adjacent).
    pure subroutine pair_sweeps_many(n, nn, nb, k, perm, bp, bi, bx, l21, d, b, x, y)
        integer, intent(in) :: n, nn, nb, k                 !! size, pairs, blocks, columns
        integer, intent(in) :: perm(n), bp(nn + 1), bi(nb)  !! permutation, block structure
        real(dp), intent(in) :: bx(4, nb), l21(nn), d(n)    !! L's blocks, diagonal blocks, D
        real(dp), intent(in) :: b(n, k)                     !! right-hand sides
        real(dp), intent(out) :: x(n, k)                    !! solutions
        real(dp), intent(out) :: y(k, n)                    !! work
        real(dp) :: y0(k), y1(k), s1(k), s2(k), s3(k), s4(k)
        integer :: jb, q, i, c
        do i = 1, n
            y(:, i) = b(perm(i), :)
        end do
        do jb = 1, nn
            y0 = y(:, 2 * jb - 1)
            y1 = y(:, 2 * jb) - l21(jb) * y0
            do q = bp(jb), bp(jb + 1) - 1
                i = bi(q)
                y(:, i) = y(:, i) - (bx(1, q) * y0 + bx(3, q) * y1)
                y(:, i + 1) = y(:, i + 1) - (bx(2, q) * y0 + bx(4, q) * y1)
            end do
            y(:, 2 * jb - 1) = y0 / d(2 * jb - 1)
            y(:, 2 * jb) = y1 / d(2 * jb)
        end do
        do jb = nn, 1, -1
            s1 = 0.0_dp; s2 = 0.0_dp; s3 = 0.0_dp; s4 = 0.0_dp
            do q = bp(jb), bp(jb + 1) - 1
                i = bi(q)
                s1 = s1 + bx(1, q) * y(:, i)
                s2 = s2 + bx(2, q) * y(:, i + 1)
                s3 = s3 + bx(3, q) * y(:, i)
                s4 = s4 + bx(4, q) * y(:, i + 1)
            end do
            y1 = y(:, 2 * jb) - (s3 + s4)
            y0 = y(:, 2 * jb - 1) - (s1 + s2) - l21(jb) * y1
            y(:, 2 * jb) = y1
            y(:, 2 * jb - 1) = y0
            do c = 1, k
                x(perm(2 * jb), c) = y1(c)
                x(perm(2 * jb - 1), c) = y0(c)
            end do
        end do
    end subroutine pair_sweeps_many

    !> The two sweeps: y = P b; L y' = y by block columns (each block's two rows updated
    !> as one 2-vector), each pair scaled by D^{-1} once final; L^T z = y' by block
    !> columns (the four products of each block summed in four partial sums), each pair
    !> stored into x = P^T z once final. Explicit-shape dummies: gfortran vectorizes the
    !> block operations only on arrays of unit stride.
    pure subroutine pair_sweeps(n, nn, nb, perm, bp, bi, bx, l21, d, b, x, y)
        integer, intent(in) :: n, nn, nb                    !! size, pairs, blocks
        integer, intent(in) :: perm(n), bp(nn + 1), bi(nb)  !! permutation, block structure
        real(dp), intent(in) :: bx(4, nb), l21(nn), d(n)    !! L's blocks, diagonal blocks, D
        real(dp), intent(in) :: b(n)                        !! right-hand side
        real(dp), intent(out) :: x(n)                       !! solution
        real(dp), intent(out) :: y(n)                       !! work
        real(dp) :: y0, y1, s(4)
        integer :: jb, q, i
        do i = 1, n
            y(i) = b(perm(i))
        end do
        do jb = 1, nn
            y0 = y(2 * jb - 1)
            y1 = y(2 * jb) - l21(jb) * y0
            do q = bp(jb), bp(jb + 1) - 1
                i = bi(q)
                y(i:i + 1) = y(i:i + 1) - (bx(1:2, q) * y0 + bx(3:4, q) * y1)
            end do
            ! the pair is final: D^{-1} now (no pass of its own)
            y(2 * jb - 1) = y0 / d(2 * jb - 1)
            y(2 * jb) = y1 / d(2 * jb)
        end do
        do jb = nn, 1, -1
            s = 0.0_dp
            do q = bp(jb), bp(jb + 1) - 1
                i = bi(q)
                s(1:2) = s(1:2) + bx(1:2, q) * y(i:i + 1)
                s(3:4) = s(3:4) + bx(3:4, q) * y(i:i + 1)
            end do
            y1 = y(2 * jb) - (s(3) + s(4))
            y0 = y(2 * jb - 1) - (s(1) + s(2)) - l21(jb) * y1
            y(2 * jb) = y1
            y(2 * jb - 1) = y0
            ! the pair is final: P^T now (no pass of its own)
            x(perm(2 * jb)) = y1
            x(perm(2 * jb - 1)) = y0
        end do
    end subroutine pair_sweeps

    !> Release the block factors.
    pure subroutine pair_ldl_free(f)
        type(pair_ldl_t), intent(inout) :: f                !! block factors
        if (allocated(f%perm)) deallocate (f%perm)
        if (allocated(f%bp)) deallocate (f%bp)
        call release_blocks(f%bi, f%bx, f%borrowed)
        if (allocated(f%l21)) deallocate (f%l21)
        if (allocated(f%d)) deallocate (f%d)
        if (allocated(f%y)) deallocate (f%y)
        if (allocated(f%ys)) deallocate (f%ys)
        if (allocated(f%cols)) deallocate (f%cols)
        f%sa = -1
        f%ss = 0
        f%n = 0
        f%nn = 0
    end subroutine pair_ldl_free
    !> The block copy of the factor P A P^T = L D L^T given by columns, as pair_ldl_build,
    !> for 3x3 blocks of the triples (3J-2, 3J-1, 3J). ok = .false. (and f empty) when L
    !> is not made of them.
    pure subroutine triple_ldl_build(f, n, perm, colptr, rowind, val, ok)
        type(triple_ldl_t), intent(inout) :: f              !! block factors (replaced)
        integer, intent(in) :: n                            !! size
        integer, intent(in) :: perm(:)                      !! (n) 0-based permutation
        integer, intent(in) :: colptr(:)                    !! (n + 1) 0-based column starts
        integer, intent(in) :: rowind(:)                    !! 0-based rows
        real(dp), intent(in) :: val(:)                      !! D and L by columns
        logical, intent(out) :: ok                          !! L is made of 3x3 blocks
        integer :: jb, c0, p(0:2), e(0:2), nb, i, m, r, t
        call triple_ldl_free(f)
        ok = .false.
        if (n < 3 .or. mod(n, 3) /= 0) return
        f%nt = n / 3
        allocate (f%perm(n), f%bp(f%nt + 1), f%ld(3, f%nt), f%d(n), f%y(4, f%nt))
        ! count the blocks and check the structure: column c0 + r holds its diagonal, the
        ! rows c0 + r + 1 .. c0 + 2 of the diagonal block, then m whole triples of rows
        ! below, the same in the three columns
        nb = 0
        do jb = 1, f%nt
            c0 = 3 * jb - 2
            do r = 0, 2
                p(r) = colptr(c0 + r) + 1
                e(r) = colptr(c0 + r + 1)
            end do
            m = e(2) - p(2)
            if (mod(m, 3) /= 0) return
            do r = 0, 2
                if (e(r) - p(r) /= m + 2 - r) return
                do t = 0, 2 - r
                    if (rowind(p(r) + t) + 1 /= c0 + r + t) return
                end do
            end do
            do i = 0, m - 1
                if (rowind(p(2) + 1 + i) /= rowind(p(0) + 3 + i) .or. &
                    rowind(p(1) + 2 + i) /= rowind(p(0) + 3 + i)) return
                if (mod(i, 3) == 0) then
                    if (mod(rowind(p(0) + 3 + i), 3) /= 0) return
                else if (rowind(p(0) + 3 + i) /= rowind(p(0) + 2 + i) + 1) then
                    return
                end if
            end do
            nb = nb + m / 3
        end do
        allocate (f%bi(nb), f%bx(9, nb + 1))
        f%bx = 0.0_dp
        f%y = 0.0_dp
        nb = 0
        do jb = 1, f%nt
            c0 = 3 * jb - 2
            do r = 0, 2
                p(r) = colptr(c0 + r) + 1
                f%d(c0 + r) = val(p(r))
            end do
            f%bp(jb) = nb + 1
            f%ld(:, jb) = [val(p(0) + 1), val(p(0) + 2), val(p(1) + 1)]
            do i = 0, (colptr(c0 + 3) - p(2)) / 3 - 1
                nb = nb + 1
                f%bi(nb) = rowind(p(0) + 3 + 3 * i) / 3 + 1
                f%bx(1:3, nb) = val(p(0) + 3 + 3 * i:p(0) + 5 + 3 * i)
                f%bx(4:6, nb) = val(p(1) + 2 + 3 * i:p(1) + 4 + 3 * i)
                f%bx(7:9, nb) = val(p(2) + 1 + 3 * i:p(2) + 3 + 3 * i)
            end do
        end do
        f%bp(f%nt + 1) = nb + 1
        f%perm = perm(1:n) + 1
        f%n = n
        ok = .true.
    end subroutine triple_ldl_build

    !> x = A^{-1} b with the 3x3 block factors (b and x: n entries; they may not alias); on
    !> two threads (triple_sweeps_two) as pair_ldl_solve decides for the 2x2 ones.
    subroutine triple_ldl_solve(f, b, x)
        type(triple_ldl_t), intent(inout) :: f              !! block factors (work vector used)
        real(dp), intent(in) :: b(:)                        !! right-hand side (n)
        real(dp), intent(out) :: x(:)                       !! solution (n)
        integer :: used
        if (f%threads == 0) call triple_ldl_threads(f, f%asked, used)
        if (f%threads >= 2 .and. f%n >= f%par_min_n .and. dc_two_usable() /= 0) then
            if (f%sa < 0) call triple_find_split(f)
            if (f%sa > 0) then
                call triple_sweeps_two(f, b, x)
                return
            end if
        end if
        call triple_sweeps(f%n, f%nt, size(f%bi), f%perm, f%bp, f%bi, f%bx, f%ld, f%d, b, x, f%y)
    end subroutine triple_ldl_solve

    !> triple_sweeps on two threads with the split of find_split, as pair_sweeps_two: the
    !> forward sweep of the two groups at once, each adding its updates of the
    !> separator's rows into a buffer of its own, those rows then b + first's + second's
    !> (this order: the same result run to run); the separator forward and back; the
    !> backward sweep of the two groups at once. The same operations as triple_sweeps but
    !> for the separator's sums (round-off).
    subroutine triple_sweeps_two(f, b, x)
        type(triple_ldl_t), target, intent(inout) :: f      !! block factors (split found)
        real(dp), target, intent(in) :: b(:)                !! right-hand side (n)
        real(dp), target, intent(out) :: x(:)               !! solution (n)
        type(two_job_t), target :: job
        integer :: nb, i, c, k, by
        real(dp) :: none(4, 1)
        nb = size(f%bi)
        job%tf => f
        job%b => b
        job%x => x
        job%sweep = 1
        by = dc_two_items(c_funloc(triple_item), c_loc(job))
        do i = f%ss, f%nt
            c = 3 * i - 2
            k = i - f%ss + 1
            f%y(1, i) = (b(f%perm(c)) + f%ys(1, k, 1)) + f%ys(1, k, 2)
            f%y(2, i) = (b(f%perm(c + 1)) + f%ys(2, k, 1)) + f%ys(2, k, 2)
            f%y(3, i) = (b(f%perm(c + 2)) + f%ys(3, k, 1)) + f%ys(3, k, 2)
            f%y(4, i) = 0.0_dp
        end do
        call triple_fwd(f%nt, nb, f%bp, f%bi, f%bx, f%ld, f%d, f%nt - f%ss + 1, &
                        f%cols(f%ss:f%nt), f%nt + 1, f%y, 1, none)
        call triple_bwd(f%n, f%nt, nb, f%perm, f%bp, f%bi, f%bx, f%ld, f%nt - f%ss + 1, &
                        f%cols(f%ss:f%nt), f%y, x)
        job%sweep = 2
        by = dc_two_items(c_funloc(triple_item), c_loc(job))
    end subroutine triple_sweeps_two

    !> Work item `item` of triple_sweeps_two (as pair_item).
    subroutine triple_item(ctx, item) bind(C)
        type(c_ptr), value :: ctx                           !! the two_job_t
        integer(c_int), value :: item                       !! 1 or 2
        type(two_job_t), pointer :: job
        integer :: t0, t1
        call c_f_pointer(ctx, job)
        associate (f => job%tf)
            t0 = merge(1, f%sa + 1, item == 1)
            t1 = merge(f%sa, f%ss - 1, item == 1)
            if (job%sweep == 1) then
                call triple_gather(f%n, f%nt, f%perm, t1 - t0 + 1, f%cols(t0:t1), job%b, f%y)
                f%ys(:, :, item) = 0.0_dp
                call triple_fwd(f%nt, size(f%bi), f%bp, f%bi, f%bx, f%ld, f%d, t1 - t0 + 1, &
                                f%cols(t0:t1), f%ss, f%y, size(f%ys, 2), f%ys(:, :, item))
            else
                call triple_bwd(f%n, f%nt, size(f%bi), f%perm, f%bp, f%bi, f%bx, f%ld, &
                                t1 - t0 + 1, f%cols(t0:t1), f%y, job%x)
            end if
        end associate
    end subroutine triple_item

    !> y's triples cl from b (P b), the fourth entries zero.
    pure subroutine triple_gather(n, nt, perm, nc, cl, b, y)
        integer, intent(in) :: n, nt                        !! size, triples
        integer, intent(in) :: perm(n)                      !! permutation
        integer, intent(in) :: nc                           !! block columns
        integer, intent(in) :: cl(nc)                       !! their indices
        real(dp), intent(in) :: b(n)                        !! right-hand side
        real(dp), intent(inout) :: y(4, nt)                 !! work
        integer :: t, c
        do t = 1, nc
            c = 3 * cl(t) - 2
            y(:, cl(t)) = [b(perm(c)), b(perm(c + 1)), b(perm(c + 2)), 0.0_dp]
        end do
    end subroutine triple_gather

    !> The forward sweep of triple_sweeps on the block columns cl (ascending; y's triples
    !> gathered): updates of block rows >= rs go into ys (row rs: ys(:, 1)), the others
    !> into y.
    pure subroutine triple_fwd(nt, nb, bp, bi, bx, ld, d, nc, cl, rs, y, ns, ys)
        integer, intent(in) :: nt, nb                       !! triples, blocks
        integer, intent(in) :: bp(nt + 1), bi(nb)          !! block structure
        real(dp), intent(in) :: bx(9 * nb + 9)              !! L's blocks (and the zero block)
        real(dp), intent(in) :: ld(3, nt), d(3 * nt)        !! diagonal blocks, D
        integer, intent(in) :: nc                           !! block columns
        integer, intent(in) :: cl(nc)                       !! their indices, ascending
        integer, intent(in) :: rs                           !! first block row kept in ys
        real(dp), intent(inout) :: y(4, nt)                 !! work (fourth row: throw-away)
        integer, intent(in) :: ns                           !! block rows of ys
        real(dp), intent(inout) :: ys(4, ns)                !! updates of block rows >= rs
        real(dp) :: y0, y1, y2
        integer :: t, jb, q, i, o, c
        do t = 1, nc
            jb = cl(t)
            y0 = y(1, jb)
            y1 = y(2, jb) - ld(1, jb) * y0
            y2 = y(3, jb) - ld(2, jb) * y0 - ld(3, jb) * y1
            do q = bp(jb), bp(jb + 1) - 1
                i = bi(q)
                o = 9 * (q - 1)
                if (i < rs) then
                    y(:, i) = y(:, i) - (bx(o + 1:o + 4) * y0 + bx(o + 4:o + 7) * y1 &
                                         + bx(o + 7:o + 10) * y2)
                else
                    ys(:, i - rs + 1) = ys(:, i - rs + 1) - (bx(o + 1:o + 4) * y0 &
                                        + bx(o + 4:o + 7) * y1 + bx(o + 7:o + 10) * y2)
                end if
            end do
            c = 3 * jb - 2
            y(1, jb) = y0 / d(c)
            y(2, jb) = y1 / d(c + 1)
            y(3, jb) = y2 / d(c + 2)
        end do
    end subroutine triple_fwd

    !> The backward sweep of triple_sweeps on the block columns cl, last first (the rows
    !> below them final), each triple stored into x = P^T z.
    pure subroutine triple_bwd(n, nt, nb, perm, bp, bi, bx, ld, nc, cl, y, x)
        integer, intent(in) :: n, nt, nb                    !! size, triples, blocks
        integer, intent(in) :: perm(n), bp(nt + 1), bi(nb)  !! permutation, block structure
        real(dp), intent(in) :: bx(9 * nb + 9)              !! L's blocks (and the zero block)
        real(dp), intent(in) :: ld(3, nt)                   !! diagonal blocks
        integer, intent(in) :: nc                           !! block columns
        integer, intent(in) :: cl(nc)                       !! their indices, ascending
        real(dp), intent(inout) :: y(4, nt)                 !! work
        real(dp), intent(inout) :: x(n)                     !! solution (the triples cl set)
        real(dp) :: y0, y1, y2, s0(4), s1(4), s2(4)
        integer :: t, jb, q, i, o, c
        do t = nc, 1, -1
            jb = cl(t)
            s0 = 0.0_dp; s1 = 0.0_dp; s2 = 0.0_dp
            do q = bp(jb), bp(jb + 1) - 1
                i = bi(q)
                o = 9 * (q - 1)
                s0 = s0 + bx(o + 1:o + 4) * y(:, i)
                s1 = s1 + bx(o + 4:o + 7) * y(:, i)
                s2 = s2 + bx(o + 7:o + 10) * y(:, i)
            end do
            y2 = y(3, jb) - ((s2(1) + s2(2)) + s2(3))
            y1 = y(2, jb) - ((s1(1) + s1(2)) + s1(3)) - ld(3, jb) * y2
            y0 = y(1, jb) - ((s0(1) + s0(2)) + s0(3)) - ld(1, jb) * y1 - ld(2, jb) * y2
            y(1, jb) = y0
            y(2, jb) = y1
            y(3, jb) = y2
            c = 3 * jb - 2
            x(perm(c)) = y0
            x(perm(c + 1)) = y1
            x(perm(c + 2)) = y2
        end do
    end subroutine triple_bwd

    !> X = A^{-1} B for the k columns of B in one pass over the factor (as
    !> pair_ldl_solve_many). Each column gets the operations of triple_ldl_solve in the
    !> same order.
    pure subroutine triple_ldl_solve_many(f, b, x, ok)
        type(triple_ldl_t), intent(in) :: f                 !! block factors
        real(dp), intent(in) :: b(:, :)                     !! right-hand sides (n, k)
        real(dp), intent(out) :: x(:, :)                    !! solutions (n, k)
        logical, intent(out) :: ok                          !! .false.: out of memory (x not set)
        real(dp), allocatable :: y(:, :)
        integer :: ist
        allocate (y(size(b, 2), f%n), stat=ist)
        ok = ist == 0
        if (.not. ok) return
        call triple_sweeps_many(f%n, f%nt, size(f%bi), size(b, 2), f%perm, f%bp, f%bi, f%bx, &
                                f%ld, f%d, b, x, y)
    end subroutine triple_ldl_solve_many

    !> The two sweeps of pair_sweeps by 3x3 blocks: L y' = P b by block columns (each
    !> block's rows updated as one padded 4-vector), D^{-1} on each triple once final;
    !> L^T z = y' by block columns (three partial 4-vectors, one for each column of the
    !> block), x = P^T z on each triple once final. y's fourth entries stay zero.
    pure subroutine triple_sweeps(n, nt, nb, perm, bp, bi, bx, ld, d, b, x, y)
        integer, intent(in) :: n, nt, nb                    !! size, triples, blocks
        integer, intent(in) :: perm(n), bp(nt + 1), bi(nb)  !! permutation, block structure
        real(dp), intent(in) :: bx(9 * nb + 9)              !! L's blocks (and the zero block)
        real(dp), intent(in) :: ld(3, nt), d(n)             !! diagonal blocks, D
        real(dp), intent(in) :: b(n)                        !! right-hand side
        real(dp), intent(out) :: x(n)                       !! solution
        real(dp), intent(inout) :: y(4, nt)                 !! work (fourth row: throw-away)
        real(dp) :: y0, y1, y2, s0(4), s1(4), s2(4)
        integer :: jb, q, i, c, o
        do jb = 1, nt
            c = 3 * jb - 2
            y(1, jb) = b(perm(c))
            y(2, jb) = b(perm(c + 1))
            y(3, jb) = b(perm(c + 2))
            y(4, jb) = 0.0_dp
        end do
        do jb = 1, nt
            y0 = y(1, jb)
            y1 = y(2, jb) - ld(1, jb) * y0
            y2 = y(3, jb) - ld(2, jb) * y0 - ld(3, jb) * y1
            do q = bp(jb), bp(jb + 1) - 1
                i = bi(q)
                o = 9 * (q - 1)
                y(:, i) = y(:, i) - (bx(o + 1:o + 4) * y0 + bx(o + 4:o + 7) * y1 &
                                     + bx(o + 7:o + 10) * y2)
            end do
            c = 3 * jb - 2
            y(1, jb) = y0 / d(c)
            y(2, jb) = y1 / d(c + 1)
            y(3, jb) = y2 / d(c + 2)
        end do
        do jb = nt, 1, -1
            s0 = 0.0_dp; s1 = 0.0_dp; s2 = 0.0_dp
            do q = bp(jb), bp(jb + 1) - 1
                i = bi(q)
                o = 9 * (q - 1)
                s0 = s0 + bx(o + 1:o + 4) * y(:, i)
                s1 = s1 + bx(o + 4:o + 7) * y(:, i)
                s2 = s2 + bx(o + 7:o + 10) * y(:, i)
            end do
            y2 = y(3, jb) - ((s2(1) + s2(2)) + s2(3))
            y1 = y(2, jb) - ((s1(1) + s1(2)) + s1(3)) - ld(3, jb) * y2
            y0 = y(1, jb) - ((s0(1) + s0(2)) + s0(3)) - ld(1, jb) * y1 - ld(2, jb) * y2
            y(1, jb) = y0
            y(2, jb) = y1
            y(3, jb) = y2
            c = 3 * jb - 2
            x(perm(c)) = y0
            x(perm(c + 1)) = y1
            x(perm(c + 2)) = y2
        end do
    end subroutine triple_sweeps

    !> triple_sweeps for k right-hand sides, the work array by rows (y(:, i): row i of
    !> the k columns, adjacent); the same operations on each column.
    pure subroutine triple_sweeps_many(n, nt, nb, k, perm, bp, bi, bx, ld, d, b, x, y)
        integer, intent(in) :: n, nt, nb, k                 !! size, triples, blocks, columns
        integer, intent(in) :: perm(n), bp(nt + 1), bi(nb)  !! permutation, block structure
        real(dp), intent(in) :: bx(9, nb + 1), ld(3, nt), d(n) !! L's blocks, diagonal blocks, D
        real(dp), intent(in) :: b(n, k)                     !! right-hand sides
        real(dp), intent(out) :: x(n, k)                    !! solutions
        real(dp), intent(out) :: y(k, n)                    !! work
        real(dp) :: y0(k), y1(k), y2(k), s(k, 3, 3)
        integer :: jb, q, i, c, j, r
        do i = 1, n
            y(:, i) = b(perm(i), :)
        end do
        do jb = 1, nt
            c = 3 * jb - 2
            y0 = y(:, c)
            y1 = y(:, c + 1) - ld(1, jb) * y0
            y2 = y(:, c + 2) - ld(2, jb) * y0 - ld(3, jb) * y1
            do q = bp(jb), bp(jb + 1) - 1
                i = 3 * bi(q) - 2
                do r = 0, 2
                    y(:, i + r) = y(:, i + r) - (bx(1 + r, q) * y0 + bx(4 + r, q) * y1 &
                                                 + bx(7 + r, q) * y2)
                end do
            end do
            y(:, c) = y0 / d(c)
            y(:, c + 1) = y1 / d(c + 1)
            y(:, c + 2) = y2 / d(c + 2)
        end do
        do jb = nt, 1, -1
            c = 3 * jb - 2
            s = 0.0_dp
            do q = bp(jb), bp(jb + 1) - 1
                i = 3 * bi(q) - 2
                do j = 1, 3          ! column j of the block
                    do r = 1, 3      ! its row r
                        s(:, r, j) = s(:, r, j) + bx(3 * (j - 1) + r, q) * y(:, i + r - 1)
                    end do
                end do
            end do
            y2 = y(:, c + 2) - ((s(:, 1, 3) + s(:, 2, 3)) + s(:, 3, 3))
            y1 = y(:, c + 1) - ((s(:, 1, 2) + s(:, 2, 2)) + s(:, 3, 2)) - ld(3, jb) * y2
            y0 = y(:, c) - ((s(:, 1, 1) + s(:, 2, 1)) + s(:, 3, 1)) - ld(1, jb) * y1 &
                 - ld(2, jb) * y2
            y(:, c) = y0
            y(:, c + 1) = y1
            y(:, c + 2) = y2
            do j = 1, k
                x(perm(c), j) = y0(j)
                x(perm(c + 1), j) = y1(j)
                x(perm(c + 2), j) = y2(j)
            end do
        end do
    end subroutine triple_sweeps_many

    !> Release the 3x3 block factors.
    pure subroutine triple_ldl_free(f)
        type(triple_ldl_t), intent(inout) :: f              !! block factors
        if (allocated(f%perm)) deallocate (f%perm)
        if (allocated(f%bp)) deallocate (f%bp)
        call release_blocks(f%bi, f%bx, f%borrowed)
        if (allocated(f%ld)) deallocate (f%ld)
        if (allocated(f%d)) deallocate (f%d)
        if (allocated(f%y)) deallocate (f%y)
        if (allocated(f%ys)) deallocate (f%ys)
        if (allocated(f%cols)) deallocate (f%cols)
        f%sa = -1
        f%ss = 0
        f%n = 0
        f%nt = 0
    end subroutine triple_ldl_free

    !> Release a block factor's rows and values: deallocated when they were allocated
    !> here (the *_ldl_build routines), only disassociated when they are borrowed.
    pure subroutine release_blocks(bi, bx, borrowed)
        integer, pointer, contiguous, intent(inout) :: bi(:)      !! block rows
        real(dp), pointer, contiguous, intent(inout) :: bx(:, :)  !! block values
        logical, intent(inout) :: borrowed                        !! owned by CHOLMOD
        if (.not. borrowed) then
            if (associated(bi)) deallocate (bi)
            if (associated(bx)) deallocate (bx)
        end if
        nullify (bi, bx)
        borrowed = .false.
    end subroutine release_blocks
end module ldl_solves
