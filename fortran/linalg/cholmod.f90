!> CHOLMOD (SuiteSparse) binding: LDL^T factorization of symmetric csc_t matrices,
!> through the flat C shim cholmod_shim.c (which owns cholmod_common and cholmod_factor;
!> Fortran only holds an opaque handle).
!>
!> P A P^T = L D L^T, L unit lower triangular, D diagonal, P CHOLMOD's fill-reducing
!> permutation. Only the upper triangle of A is read. A zero, negative or non-finite
!> pivot gives STAT_NUMERIC ('not positive definite'): the caller decides what to do
!> (linear_solver falls back to UMFPACK's LU). The numerical factorization is CHOLMOD's
!> simplicial LDL^T, or its supernodal LL^T where the factor's columns are long (3D, from
!> some 10^4 dofs: faster; a rule on the pattern alone; chol_factor's `supernodal`).
!>
!> Ordering: AMD, CHOLMOD's nested dissection or (3D) METIS, whichever gives L the fewest
!> entries (a rule on the pattern alone, so runs are deterministic; chol_ordering).
!> Solves: when the matrix is made of the 2x2 blocks of node pairs, or of the 3x3 blocks
!> of node triples (the shim then orders the nodes' dofs together), CHOLMOD's factor is
!> turned by blocks in place (the supernodal LL^T into LDL^T on the way) and solved with
!> ldl_solves' sweeps (about 1.4x faster than cholmod_solve2 on the same factor in 2D;
!> docs/performance.md): one copy of the factor at any time (keep_cholmod keeps
!> CHOLMOD's and copies it instead); otherwise through cholmod_solve2 with workspaces
!> kept in the shim (no allocation per solve): own scalar loops on the copied factors are
!> slower than CHOLMOD's, which treats chains of up to 3 columns with the same pattern at
!> once (docs/performance.md, "The solves").
!> A cholmod_t owns a C handle: never copy one by assignment (double free).
module cholmod
    use iso_c_binding, only: c_ptr, c_null_ptr, c_int, c_long, c_double, c_associated, &
                             c_f_pointer, c_char
    use kinds, only: dp
    use errors, only: STAT_OK, STAT_BAD_INPUT, STAT_NUMERIC, STAT_INTERNAL, STAT_INTERRUPTED, &
                      raise, oom_text, mb_text, OOM_HINT_FACTOR
    use text, only: int_text
    use sparse, only: csc_t
    use ldl_solves, only: pair_ldl_t, pair_ldl_build, pair_ldl_solve, pair_ldl_solve_many, &
                          pair_ldl_free, triple_ldl_t, triple_ldl_build, triple_ldl_solve, &
                          triple_ldl_solve_many, triple_ldl_free
    implicit none
    private

    ! Statuses of cholmod_shim.c.
    integer(c_int), parameter :: DC_OK = 0, DC_NOT_POSDEF = 1, DC_OUT_OF_MEMORY = 2, &
                                 DC_OUT_OF_MEMORY_ORDERING = 4, DC_INTERRUPTED = 5

    !> LDL^T factors of one symmetric matrix (the symbolic analysis is kept across
    !> numeric refactorizations of the same pattern).
    type, public :: cholmod_t
        type(c_ptr) :: handle = c_null_ptr       !! cholmod_shim handle
        integer :: n = 0                         !! size factorized (0: no factors)
        integer :: lnz = 0                       !! entries of L below the diagonal
        integer :: factorizations = 0            !! numeric factorizations done (kept by chol_free)
        integer :: analyses = 0                  !! symbolic analyses done (kept by chol_free)
        integer :: ordering = 0                  !! ORDERING_NAMES index of the analysis (0: none)
        logical :: supernodal = .false.          !! CHOLMOD's supernodal LL^T (solved by cholmod_solve2)
        integer(c_long) :: factor_nnz = 0        !! entries of the factor kept (D and L)
        logical :: keep_cholmod = .false.        !! keep CHOLMOD's factor next to the block
                                                 !! copy (chol_solve_cholmod; tests, floors);
                                                 !! a supernodal one is then not copied by
                                                 !! blocks (solves by cholmod_solve2)
        logical :: few_solves = .false.          !! the factor serves a few solves only: one
                                                 !! without node blocks may then be
                                                 !! supernodal (cholmod_shim's use_supernodal)
        type(pair_ldl_t) :: pairs                !! the factor by 2x2 blocks (pairs%n = 0: none)
        type(triple_ldl_t) :: triples            !! the factor by 3x3 blocks (triples%n = 0: none)
    end type cholmod_t

    !> Names of the triangular solves (chol_kernel).
    character(len=*), parameter, public :: KERNEL_PAIRS = 'ldl_node_pairs'     !! ldl_solves, 2x2
    character(len=*), parameter, public :: KERNEL_TRIPLES = 'ldl_node_triples' !! ldl_solves, 3x3
    character(len=*), parameter, public :: KERNEL_CHOLMOD = 'cholmod_solve2'   !! CHOLMOD's, simplicial
    character(len=*), parameter, public :: KERNEL_SUPERNODAL = 'cholmod_supernodal' !! CHOLMOD's, supernodal

    !> Fill-reducing orderings (dc_cholmod_ordering's codes 1..4): of the node blocks'
    !> graph when they are ordered together, else CHOLMOD's own choice.
    character(len=*), parameter, public :: ORDERING_NAMES(4) = &
        [character(len=8) :: 'amd', 'metis', 'nesdis', 'cholmod']

    public :: chol_factor, chol_analyse, chol_solve, chol_ordering, chol_solve_many, &
              chol_free, chol_kernel, &
              chol_solve_cholmod, chol_blas

    interface
        !> void *dc_cholmod_new(void)
        function dc_cholmod_new() result(h) bind(C, name='dc_cholmod_new')
            import :: c_ptr
            type(c_ptr) :: h
        end function dc_cholmod_new

        !> void dc_cholmod_free(void *h)
        subroutine dc_cholmod_free(h) bind(C, name='dc_cholmod_free')
            import :: c_ptr
            type(c_ptr), value :: h                      !! handle
        end subroutine dc_cholmod_free

        !> int dc_cholmod_factor(h, n, colptr, rowind, val, &analysed, &lnz, &minor, &paired)
        function dc_cholmod_factor(h, n, colptr, rowind, val, analysed, lnz, minor, paired) &
            result(status) bind(C, name='dc_cholmod_factor')
            import :: c_ptr, c_int, c_long, c_double
            type(c_ptr), value :: h                      !! handle
            integer(c_int), value :: n                   !! size
            integer(c_int), intent(in) :: colptr(*)      !! column starts (0-based)
            integer(c_int), intent(in) :: rowind(*)      !! row indices (0-based)
            real(c_double), intent(in) :: val(*)         !! values
            integer(c_int), intent(out) :: analysed      !! 1 if the analysis was redone
            integer(c_long), intent(out) :: lnz          !! entries of L below the diagonal
            integer(c_int), intent(out) :: minor         !! failing column (0-based) or -1
            integer(c_int), intent(out) :: paired        !! size of the node blocks ordered together (2, 3) or 0
            integer(c_int) :: status
        end function dc_cholmod_factor

        !> int dc_cholmod_analyse(h, n, colptr, rowind, val, &analysed, &entries)
        function dc_cholmod_analyse(h, n, colptr, rowind, val, analysed, entries) &
            result(status) bind(C, name='dc_cholmod_analyse')
            import :: c_ptr, c_int, c_double
            type(c_ptr), value :: h                      !! handle
            integer(c_int), value :: n                   !! size
            integer(c_int), intent(in) :: colptr(*)      !! column starts (0-based)
            integer(c_int), intent(in) :: rowind(*)      !! row indices (0-based)
            real(c_double), intent(in) :: val(*)         !! values (not read by the analysis)
            integer(c_int), intent(out) :: analysed      !! 1 if the analysis was redone
            real(c_double), intent(out) :: entries       !! entries the factor will store (D and L)
            integer(c_int) :: status
        end function dc_cholmod_analyse

        !> void dc_cholmod_need(h, need)
        subroutine dc_cholmod_need(h, need) bind(C, name='dc_cholmod_need')
            import :: c_ptr, c_double
            type(c_ptr), value :: h                      !! handle
            real(c_double), intent(out) :: need(4)       !! factor, work, BLAS buffer, threads
        end subroutine dc_cholmod_need

        !> double dc_cholmod_entries(h)
        function dc_cholmod_entries(h) result(entries) bind(C, name='dc_cholmod_entries')
            import :: c_ptr, c_double
            type(c_ptr), value :: h                      !! handle
            real(c_double) :: entries
        end function dc_cholmod_entries

        !> long dc_cholmod_nnz(h)
        function dc_cholmod_nnz(h) result(nnz) bind(C, name='dc_cholmod_nnz')
            import :: c_ptr, c_long
            type(c_ptr), value :: h                      !! handle
            integer(c_long) :: nnz
        end function dc_cholmod_nnz

        !> int dc_cholmod_export(h, perm, colptr, rowind, val)
        function dc_cholmod_export(h, perm, colptr, rowind, val) result(status) &
            bind(C, name='dc_cholmod_export')
            import :: c_ptr, c_int, c_double
            type(c_ptr), value :: h                      !! handle
            integer(c_int), intent(out) :: perm(*)       !! (n) 0-based permutation
            integer(c_int), intent(out) :: colptr(*)     !! (n + 1) 0-based column starts
            integer(c_int), intent(out) :: rowind(*)     !! (nnz) 0-based rows
            real(c_double), intent(out) :: val(*)        !! (nnz) D and L by columns
            integer(c_int) :: status
        end function dc_cholmod_export

        !> int dc_cholmod_take_blocks(h, bs, perm, bp, d, ld, &nb, &bx, &bi)
        function dc_cholmod_take_blocks(h, bs, perm, bp, d, ld, nb, bx, bi) result(status) &
            bind(C, name='dc_cholmod_take_blocks')
            import :: c_ptr, c_int, c_long, c_double
            type(c_ptr), value :: h                      !! handle
            integer(c_int), value :: bs                  !! block size (2, 3)
            integer(c_int), intent(out) :: perm(*)       !! (n) 1-based permutation
            integer(c_int), intent(out) :: bp(*)         !! (n / bs + 1) first block of each block column
            real(c_double), intent(out) :: d(*)          !! (n) D
            real(c_double), intent(out) :: ld(*)         !! L in the diagonal blocks
            integer(c_long), intent(out) :: nb           !! blocks below the diagonal blocks
            type(c_ptr), intent(out) :: bx               !! the blocks' values (CHOLMOD's memory)
            type(c_ptr), intent(out) :: bi               !! the blocks' rows (CHOLMOD's memory)
            integer(c_int) :: status
        end function dc_cholmod_take_blocks

        !> void dc_cholmod_few_solves(h, few)
        subroutine dc_cholmod_few_solves(h, few) bind(C, name='dc_cholmod_few_solves')
            import :: c_ptr, c_int
            type(c_ptr), value :: h                      !! handle
            integer(c_int), value :: few                 !! 1: a few solves only, 0: many
        end subroutine dc_cholmod_few_solves

        !> int dc_cholmod_supernodal(h)
        function dc_cholmod_supernodal(h) result(code) bind(C, name='dc_cholmod_supernodal')
            import :: c_ptr, c_int
            type(c_ptr), value :: h                      !! handle
            integer(c_int) :: code
        end function dc_cholmod_supernodal

        !> void dc_cholmod_blas(msg, len)
        subroutine dc_cholmod_blas(msg, n) bind(C, name='dc_cholmod_blas')
            import :: c_int, c_char
            character(kind=c_char), intent(out) :: msg(*)  !! the text, blank-padded
            integer(c_int), value :: n                     !! length of msg
        end subroutine dc_cholmod_blas

        !> int dc_cholmod_ordering(h)
        function dc_cholmod_ordering(h) result(code) bind(C, name='dc_cholmod_ordering')
            import :: c_ptr, c_int
            type(c_ptr), value :: h                      !! handle
            integer(c_int) :: code
        end function dc_cholmod_ordering

        !> int dc_cholmod_release_numeric(h)
        function dc_cholmod_release_numeric(h) result(status) &
            bind(C, name='dc_cholmod_release_numeric')
            import :: c_ptr, c_int
            type(c_ptr), value :: h                      !! handle
            integer(c_int) :: status
        end function dc_cholmod_release_numeric

        !> int dc_cholmod_solve(h, ncol, b, x)
        function dc_cholmod_solve(h, ncol, b, x) result(status) bind(C, name='dc_cholmod_solve')
            import :: c_ptr, c_int, c_double
            type(c_ptr), value :: h                      !! handle
            integer(c_int), value :: ncol                !! right-hand sides
            real(c_double), intent(in) :: b(*)           !! (n, ncol)
            real(c_double), intent(out) :: x(*)          !! (n, ncol)
            integer(c_int) :: status
        end function dc_cholmod_solve
    end interface

contains

    !> What chol_analyse and chol_factor do first: release the factors, check the csc_t
    !> and the values read (`val` when given, else a%val; STAT_BAD_INPUT when empty or
    !> inconsistent) and create CHOLMOD's handle (STAT_INTERNAL when out of memory);
    !> `who` names the caller in the message.
    subroutine chol_prepare(ch, a, who, stat, errmsg, val)
        type(cholmod_t), intent(inout) :: ch                !! factors (released)
        type(csc_t), intent(in) :: a                        !! symmetric matrix
        character(len=*), intent(in) :: who                !! caller, for the message
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp), intent(in), optional :: val(:)            !! values on a's pattern (for a%val)
        logical :: has_val
        integer :: nval
        stat = STAT_OK
        ch%n = 0
        ch%supernodal = .false.
        call pair_ldl_free(ch%pairs)
        call triple_ldl_free(ch%triples)
        if (present(val)) then
            has_val = .true.
            nval = size(val)
        else
            has_val = allocated(a%val)
            nval = 0
            if (has_val) nval = size(a%val)
        end if
        if (a%n < 1 .or. .not. (allocated(a%colptr) .and. allocated(a%rowind) .and. has_val)) then
            call raise(stat, errmsg, STAT_BAD_INPUT, who//': matrix is empty or not allocated')
            return
        end if
        if (size(a%colptr) < a%n + 1 .or. a%colptr(1) /= 0 .or. a%colptr(a%n + 1) /= a%nnz &
            .or. size(a%rowind) < a%nnz .or. nval < a%nnz) then
            call raise(stat, errmsg, STAT_BAD_INPUT, who//': inconsistent CSC arrays')
            return
        end if
        if (.not. c_associated(ch%handle)) ch%handle = dc_cholmod_new()
        if (.not. c_associated(ch%handle)) then
            call raise(stat, errmsg, STAT_INTERNAL, who//': out of memory')
            return
        end if
        call dc_cholmod_few_solves(ch%handle, merge(1_c_int, 0_c_int, ch%few_solves))
    end subroutine chol_prepare

    !> The symbolic analysis of chol_factor alone (ordering chosen, no numerical
    !> factorization): `entries` = the entries the factor of a will store (D and L, what
    !> chol_factor then reports as factor_nnz). The analysis is kept in ch, so the next
    !> chol_factor of the same pattern does not redo it; ch holds no factors after this.
    !> CHOLMOD errors give STAT_INTERNAL; an inconsistent csc_t gives STAT_BAD_INPUT; a
    !> stop signal caught before an ordering tried (module stop_signal) STAT_INTERRUPTED.
    !> The analysis reads a's pattern alone: a matrix on a's pattern with other values
    !> (`val`, see chol_factor) has the same.
    subroutine chol_analyse(ch, a, entries, stat, errmsg, val)
        type(cholmod_t), intent(inout) :: ch                !! analysis (factors released)
        type(csc_t), intent(in) :: a                        !! symmetric matrix
        integer(c_long), intent(out) :: entries             !! the factor's entries
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp), intent(in), optional :: val(:)            !! values on a's pattern (for a%val)
        integer(c_int) :: status, analysed
        real(c_double) :: e
        entries = 0
        call chol_prepare(ch, a, 'chol_analyse', stat, errmsg, val)
        if (stat /= STAT_OK) return
        if (present(val)) then
            status = dc_cholmod_analyse(ch%handle, int(a%n, c_int), a%colptr, a%rowind, val, &
                                        analysed, e)
        else
            status = dc_cholmod_analyse(ch%handle, int(a%n, c_int), a%colptr, a%rowind, a%val, &
                                        analysed, e)
        end if
        if (status == DC_OUT_OF_MEMORY_ORDERING) then
            call raise(stat, errmsg, STAT_INTERNAL, ordering_oom_text(a))
            return
        end if
        if (status == DC_INTERRUPTED) then
            call raise(stat, errmsg, STAT_INTERRUPTED, 'interrupted during the ordering')
            return
        end if
        if (status /= DC_OK) then
            call raise(stat, errmsg, STAT_INTERNAL, 'chol_analyse: CHOLMOD failed')
            return
        end if
        if (analysed /= 0) ch%analyses = ch%analyses + 1
        entries = int(e, c_long)
        stat = STAT_OK
    end subroutine chol_analyse

    !> Factorize the symmetric matrix a (its upper triangle is read): P A P^T = L D L^T,
    !> simplicial. The analysis is redone only when n or the pattern changed. A zero,
    !> negative or non-finite pivot gives STAT_NUMERIC (no factors kept); CHOLMOD
    !> errors give STAT_INTERNAL; an inconsistent csc_t gives STAT_BAD_INPUT; a stop signal
    !> caught before an ordering tried, before the numerical factorization or before a
    !> range of rows of a simplicial one (module stop_signal) STAT_INTERRUPTED, no factors
    !> kept (the supernodal factorization is one CHOLMOD call). With `val`,
    !> the matrix factorized has a's pattern and the values val (a%val is not read): a
    !> matrix kept as values on another's pattern (J0 on the model's) needs no copy of it.
    subroutine chol_factor(ch, a, stat, errmsg, val)
        type(cholmod_t), intent(inout) :: ch                !! factors (created or replaced)
        type(csc_t), intent(in) :: a                        !! symmetric matrix (its pattern)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp), intent(in), optional :: val(:)            !! (a%nnz) values on a's pattern
        integer(c_int) :: status, analysed, minor, paired
        integer(c_long) :: lnz
        character(len=160) :: buf

        call chol_prepare(ch, a, 'chol_factor', stat, errmsg, val)
        if (stat /= STAT_OK) return
        if (present(val)) then
            status = dc_cholmod_factor(ch%handle, int(a%n, c_int), a%colptr, a%rowind, val, &
                                       analysed, lnz, minor, paired)
        else
            status = dc_cholmod_factor(ch%handle, int(a%n, c_int), a%colptr, a%rowind, a%val, &
                                       analysed, lnz, minor, paired)
        end if
        if (analysed /= 0) ch%analyses = ch%analyses + 1
        ch%factorizations = ch%factorizations + 1
        select case (status)
        case (DC_OK)
        case (DC_NOT_POSDEF)
            write (buf, '(a, i0, a)') 'chol_factor: not positive definite (pivot ', minor + 1, &
                ' is zero, negative or not finite)'
            call raise(stat, errmsg, STAT_NUMERIC, trim(buf))
            return
        case (DC_OUT_OF_MEMORY)
            call raise(stat, errmsg, STAT_INTERNAL, factor_oom_text(ch))
            return
        case (DC_OUT_OF_MEMORY_ORDERING)
            call raise(stat, errmsg, STAT_INTERNAL, ordering_oom_text(a))
            return
        case (DC_INTERRUPTED)
            call raise(stat, errmsg, STAT_INTERRUPTED, 'interrupted during the factorization')
            return
        case default
            call raise(stat, errmsg, STAT_INTERNAL, 'chol_factor: CHOLMOD failed')
            return
        end select

        ch%lnz = int(lnz)
        ch%n = a%n
        ch%ordering = int(dc_cholmod_ordering(ch%handle))
        ch%supernodal = dc_cholmod_supernodal(ch%handle) /= 0
        ch%factor_nnz = lnz + a%n
        stat = STAT_OK
        if (paired /= 0) call copy_blocks(int(paired))

    contains

        !> The factor by bs x bs blocks, bs = 2 or 3: turned so in place in CHOLMOD's
        !> memory (one copy of the factor at any time), or, with keep_cholmod, copied
        !> (CHOLMOD's factor kept for chol_solve_cholmod). Left empty, the solves going
        !> through cholmod_solve2, if the factor is not made of them.
        subroutine copy_blocks(bs)
            integer, intent(in) :: bs                       !! block size
            integer(c_int), allocatable :: perm(:), colptr(:), rowind(:)
            real(c_double), allocatable :: val(:)
            integer(c_long) :: nnz
            logical :: ok
            if (.not. ch%keep_cholmod) then
                if (take_blocks(bs)) return
            end if
            nnz = dc_cholmod_nnz(ch%handle)
            if (nnz < 0) return
            allocate (perm(a%n), colptr(a%n + 1), rowind(nnz), val(nnz))
            if (dc_cholmod_export(ch%handle, perm, colptr, rowind, val) /= DC_OK) return
            ! one copy of the factor: CHOLMOD's values go before the block copy is built
            ! (the symbolic analysis stays for the next factorization)
            if (.not. ch%keep_cholmod) then
                if (dc_cholmod_release_numeric(ch%handle) /= DC_OK) then
                    ch%n = 0
                    call raise(stat, errmsg, STAT_INTERNAL, 'chol_factor: CHOLMOD failed')
                    return
                end if
            end if
            if (bs == 3) then
                call triple_ldl_build(ch%triples, a%n, perm, colptr, rowind, val, ok)
            else
                call pair_ldl_build(ch%pairs, a%n, perm, colptr, rowind, val, ok)
            end if
            if (.not. ok) then
                ! not reached: an ordering that keeps the blocks together gives bs x bs blocks
                call pair_ldl_free(ch%pairs)
                call triple_ldl_free(ch%triples)
                if (.not. ch%keep_cholmod) then
                    ch%n = 0
                    call raise(stat, errmsg, STAT_INTERNAL, &
                               'chol_factor: the factor is not made of node blocks')
                end if
            end if
        end subroutine copy_blocks

        !> CHOLMOD's factor turned into the block factor in place (dc_cholmod_take_blocks);
        !> .false. (CHOLMOD's factor untouched) if it is not made of bs x bs blocks.
        logical function take_blocks(bs) result(done)
            integer, intent(in) :: bs                       !! block size
            integer(c_int), allocatable :: perm(:), bp(:)
            real(c_double), allocatable :: d(:), ld(:)
            integer(c_long) :: nb
            type(c_ptr) :: pbx, pbi
            integer :: nblk
            nblk = a%n / bs
            allocate (perm(a%n), bp(nblk + 1), d(a%n), ld(nblk * (bs * (bs - 1)) / 2))
            done = dc_cholmod_take_blocks(ch%handle, int(bs, c_int), perm, bp, d, ld, nb, &
                                          pbx, pbi) == DC_OK
            if (.not. done) return
            if (bs == 3) then
                associate (f => ch%triples)
                    f%nt = nblk
                    call move_alloc(perm, f%perm)
                    call move_alloc(bp, f%bp)
                    call move_alloc(d, f%d)
                    f%ld = reshape(ld, [3, nblk])
                    allocate (f%y(4, nblk))
                    f%y = 0.0_dp
                    call c_f_pointer(pbx, f%bx, [9_c_long, nb + 1])
                    call c_f_pointer(pbi, f%bi, [nb])
                    f%borrowed = .true.
                    f%n = a%n
                end associate
            else
                associate (f => ch%pairs)
                    f%nn = nblk
                    call move_alloc(perm, f%perm)
                    call move_alloc(bp, f%bp)
                    call move_alloc(d, f%d)
                    call move_alloc(ld, f%l21)
                    allocate (f%y(a%n))
                    call c_f_pointer(pbx, f%bx, [4_c_long, nb])
                    call c_f_pointer(pbi, f%bi, [nb])
                    f%borrowed = .true.
                    f%n = a%n
                end associate
            end if
        end function take_blocks
    end subroutine chol_factor

    !> The line of a symbolic analysis (the fill-reducing orderings) that ran out of memory.
    function ordering_oom_text(a) result(msg)
        type(csc_t), intent(in) :: a                        !! the matrix analysed
        character(len=:), allocatable :: msg
        msg = oom_text('the ordering (the symbolic analysis of the factorization)', &
                       'a matrix of '//int_text(a%n)//' rows and '//int_text(a%nnz)// &
                       ' entries', OOM_HINT_FACTOR)
    end function ordering_oom_text

    !> The line of a numerical factorization that ran out of memory: the factor's entries
    !> (from the symbolic analysis) and the bytes it was to hold, with its work, the BLAS's
    !> buffer and the stacks of CHOLMOD's threads where they were still to be made
    !> (dc_cholmod_need).
    function factor_oom_text(ch) result(msg)
        type(cholmod_t), intent(in) :: ch                   !! the factors that failed
        character(len=:), allocatable :: msg
        real(dp) :: entries, need(4)
        character(len=:), allocatable :: what, hint
        entries = dc_cholmod_entries(ch%handle)
        call dc_cholmod_need(ch%handle, need)
        what = ''
        if (entries > 0.0_dp) what = 'the factor has '//int_text(int(entries, c_long))// &
            ' entries (from the symbolic analysis)'
        if (need(1) > 0.0_dp) then
            if (len(what) > 0) what = what//', '
            what = what//mb_text(need(1))
            if (sum(need(2:4)) > 0.0_dp) then
                what = what//', '//mb_text(sum(need))//' with its work'
                if (need(3) > 0.0_dp) what = what//', the BLAS''s '//mb_text(need(3))//' buffer'
                if (need(4) > 0.0_dp) what = what//' and the stacks of CHOLMOD''s threads'
            end if
        end if
        hint = OOM_HINT_FACTOR
        if (need(4) > 0.0_dp) hint = hint//' (OMP_THREAD_LIMIT=1: no threads'' stacks, '// &
            mb_text(need(4))//' less)'
        msg = oom_text('the factorization', what, hint)
    end function factor_oom_text

    !> The fill-reducing ordering of the factors ('' without factors): see ORDERING_NAMES.
    pure function chol_ordering(ch) result(name)
        type(cholmod_t), intent(in) :: ch                   !! factors
        character(len=:), allocatable :: name
        name = ''
        if (ch%n >= 1 .and. ch%ordering >= 1 .and. ch%ordering <= size(ORDERING_NAMES)) &
            name = trim(ORDERING_NAMES(ch%ordering))
    end function chol_ordering

    !> The BLAS library the factorizations call (OpenBLAS's configuration and the file,
    !> or the file alone; '' where the loader cannot tell): summary.json's "blas".
    function chol_blas() result(name)
        character(len=:), allocatable :: name
        character(len=1024) :: buf
        call dc_cholmod_blas(buf, int(len(buf), c_int))
        name = trim(buf)
    end function chol_blas

    !> The triangular solve chol_solve uses: KERNEL_PAIRS, KERNEL_TRIPLES, KERNEL_CHOLMOD or
    !> KERNEL_SUPERNODAL ('' without factors).
    pure function chol_kernel(ch) result(name)
        type(cholmod_t), intent(in) :: ch                   !! factors
        character(len=:), allocatable :: name
        if (ch%n < 1) then
            name = ''
        else if (ch%pairs%n > 0) then
            name = KERNEL_PAIRS
        else if (ch%triples%n > 0) then
            name = KERNEL_TRIPLES
        else if (ch%supernodal) then
            name = KERNEL_SUPERNODAL
        else
            name = KERNEL_CHOLMOD
        end if
    end function chol_kernel

    !> Solve A x = b: by 2x2 or 3x3 blocks when the factor was copied so (ldl_solves), else with
    !> cholmod_solve2 (workspaces reused, no allocation after the first call). b and x
    !> must have n entries (STAT_BAD_INPUT otherwise, or without factors); STAT_INTERNAL
    !> if CHOLMOD fails.
    subroutine chol_solve(ch, b, x, stat, errmsg)
        type(cholmod_t), intent(inout) :: ch                !! factors
        real(dp), intent(in) :: b(:)                        !! right-hand side (n)
        real(dp), intent(out) :: x(:)                       !! solution (n)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        call solve_one(ch, b, x, .true., 'chol_solve', stat, errmsg)
    end subroutine chol_solve

    !> Solve A x = b with cholmod_solve2 whatever chol_solve uses (to compare the two:
    !> the benchmark's floors and the tests). Needs CHOLMOD's factor: with a block copy it
    !> is kept only when ch%keep_cholmod was set before chol_factor (STAT_BAD_INPUT
    !> otherwise). Errors as chol_solve.
    subroutine chol_solve_cholmod(ch, b, x, stat, errmsg)
        type(cholmod_t), intent(inout) :: ch                !! factors
        real(dp), intent(in) :: b(:)                        !! right-hand side (n)
        real(dp), intent(out) :: x(:)                       !! solution (n)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        call solve_one(ch, b, x, .false., 'chol_solve_cholmod', stat, errmsg)
    end subroutine chol_solve_cholmod

    !> The checks and the solve of chol_solve (pairs = .true.: the block factor when there
    !> is one) and chol_solve_cholmod (.false.); who names the caller in the messages.
    subroutine solve_one(ch, b, x, pairs, who, stat, errmsg)
        type(cholmod_t), intent(inout) :: ch                !! factors
        real(dp), intent(in) :: b(:)                        !! right-hand side (n)
        real(dp), intent(out) :: x(:)                       !! solution (n)
        logical, intent(in) :: pairs                        !! may use the block factor
        character(len=*), intent(in) :: who                 !! caller, for the messages
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        if (ch%n < 1) then
            call raise(stat, errmsg, STAT_BAD_INPUT, who//': no factors')
            return
        end if
        if (size(b) /= ch%n .or. size(x) /= ch%n) then
            call raise(stat, errmsg, STAT_BAD_INPUT, who//': b or x does not have n entries')
            return
        end if
        stat = STAT_OK
        if (pairs .and. ch%pairs%n > 0) then
            call pair_ldl_solve(ch%pairs, b, x)
        else if (pairs .and. ch%triples%n > 0) then
            call triple_ldl_solve(ch%triples, b, x)
        else if ((ch%pairs%n > 0 .or. ch%triples%n > 0) .and. .not. ch%keep_cholmod) then
            call raise(stat, errmsg, STAT_BAD_INPUT, who//': CHOLMOD''s factor was released')
        else
            call solve2(ch, 1, b, x, who, stat, errmsg)
        end if
    end subroutine solve_one

    !> Solve A X = B for all columns of B: in one pass over the block factors for all
    !> columns (pair_ldl_solve_many, triple_ldl_solve_many), else in one cholmod_solve2 call.
    subroutine chol_solve_many(ch, b, x, stat, errmsg)
        type(cholmod_t), intent(inout) :: ch                !! factors
        real(dp), intent(in) :: b(:, :)                     !! right-hand sides (n, m)
        real(dp), intent(out) :: x(:, :)                    !! solutions (n, m)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        logical :: ok
        if (ch%n < 1) then
            call raise(stat, errmsg, STAT_BAD_INPUT, 'chol_solve_many: no factors')
            return
        end if
        if (size(b, 1) /= ch%n .or. size(x, 1) /= ch%n .or. size(b, 2) /= size(x, 2)) then
            call raise(stat, errmsg, STAT_BAD_INPUT, 'chol_solve_many: b or x has a bad shape')
            return
        end if
        stat = STAT_OK
        if (size(b, 2) == 0) return
        if (ch%pairs%n > 0 .or. ch%triples%n > 0) then
            if (ch%pairs%n > 0) then
                call pair_ldl_solve_many(ch%pairs, b, x, ok)
            else
                call triple_ldl_solve_many(ch%triples, b, x, ok)
            end if
            if (.not. ok) call raise(stat, errmsg, STAT_INTERNAL, oom_text('the solves of '// &
                int_text(size(b, 2))//' columns', mb_text(8.0_dp * size(b)), OOM_HINT_FACTOR))
            return
        end if
        call solve2(ch, size(b, 2), b, x, 'chol_solve_many', stat, errmsg)
    end subroutine chol_solve_many

    !> cholmod_solve2 for ncol right-hand sides: STAT_INTERNAL when it fails, with the
    !> out of memory line when its workspaces could not be allocated.
    subroutine solve2(ch, ncol, b, x, who, stat, errmsg)
        type(cholmod_t), intent(inout) :: ch                !! factors
        integer, intent(in) :: ncol                         !! right-hand sides
        real(dp), intent(in) :: b(*)                        !! (n, ncol)
        real(dp), intent(out) :: x(*)                       !! (n, ncol)
        character(len=*), intent(in) :: who                 !! caller, for the message
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer(c_int) :: status
        stat = STAT_OK
        status = dc_cholmod_solve(ch%handle, int(ncol, c_int), b, x)
        if (status == DC_OUT_OF_MEMORY) then
            call raise(stat, errmsg, STAT_INTERNAL, oom_text('the solves of '// &
                       int_text(ncol)//' columns', 'their work, about '// &
                       mb_text(24.0_dp * ch%n * ncol), OOM_HINT_FACTOR))
        else if (status /= DC_OK) then
            call raise(stat, errmsg, STAT_INTERNAL, who//': cholmod_solve2 failed')
        end if
    end subroutine solve2

    !> Release the CHOLMOD objects and the copied factors (safe to call twice or on a
    !> fresh cholmod_t). The counters are kept.
    subroutine chol_free(ch)
        type(cholmod_t), intent(inout) :: ch   !! factors to release
        if (c_associated(ch%handle)) call dc_cholmod_free(ch%handle)
        ch%handle = c_null_ptr
        call pair_ldl_free(ch%pairs)
        call triple_ldl_free(ch%triples)
        ch%n = 0
        ch%lnz = 0
        ch%factor_nnz = 0
        ch%ordering = 0
        ch%supernodal = .false.
    end subroutine chol_free
end module cholmod
