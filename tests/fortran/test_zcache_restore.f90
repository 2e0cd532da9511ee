!> The column cache's checkpoint (contact_columns: zcache_save, zcache_load,
!> zcache_restore, zcache_basis_reform, zcache_restore_finish). A cache is driven by a
!> random sequence of steps (columns of Z needed, basis vectors Z b_k needed) under a
!> budget that drops groups and basis columns, saved after one step, and restored into a
!> new cache; the steps after it then leave both caches alike, bit for bit: the counters
!> (columns solved, dropped), bytes, groups held and their steps, the columns of Z and W,
!> the basis columns with their slots, steps and ranges. Several save points, among them
!> one where a basis column is held while a group it was formed from was dropped (its
!> restore solves that group and drops it again). Exit status 1 on any failure.
program test_zcache_restore
    use kinds, only: dp, i8
    use errors, only: STAT_OK
    use sparse, only: csc_t, csc_from_coo
    use linear_solver, only: factor_t, ls_factor
    use byte_buffer, only: byte_buffer_t, buf_from
    use contact_columns, only: zcache_t, zcache_init, zcache_new_step, zcache_ensure, &
                               zcache_basis_init, zcache_basis_ensure, zcache_save, &
                               zcache_load, zcache_restore, zcache_basis_reform, &
                               zcache_restore_finish
    use unit_checks, only: checks_t, seed
    implicit none
    !> dofs, contact-cell dofs (5 groups), basis vectors, steps, columns a step needs
    integer, parameter :: N = 150, M = 75, NB = 24, STEPS = 60, NEED = 10
    !> entries of a basis vector
    integer, parameter :: NE = 3
    !> the budget: about 20 columns (W's M and Z's N entries each) and a few basis columns
    integer(i8), parameter :: BUDGET = 8_i8 * (M + N) * 20
    type(checks_t) :: checks
    type(csc_t) :: a
    type(factor_t) :: lu
    integer :: cdofs(M), needs(NEED, STEPS), bcols(NE, NB), bneed(4, STEPS)
    real(dp) :: bcoef(NE, NB)
    integer :: save_at, stat, covered
    logical :: dropped_under_basis
    character(len=200) :: msg

    call seed(4711)
    call build_matrix()
    call random_sequence()
    covered = 0
    do save_at = 5, STEPS - 5, 3
        call check_restart(save_at, dropped_under_basis)
        if (dropped_under_basis) covered = covered + 1
    end do
    call checks%check(covered > 0, 'some save point holds a basis column whose group was dropped')
    call checks%finish('test_zcache_restore')

contains

    !> J0: a shifted 1D Laplacian (symmetric positive definite), factorized directly;
    !> the contact-cell dofs: every second dof from 1.
    subroutine build_matrix()
        integer :: rows(3 * N), cols(3 * N), k, i
        real(dp) :: vals(3 * N)
        k = 0
        do i = 1, N
            k = k + 1; rows(k) = i; cols(k) = i; vals(k) = 2.5_dp
            if (i > 1) then
                k = k + 1; rows(k) = i; cols(k) = i - 1; vals(k) = -1.0_dp
            end if
            if (i < N) then
                k = k + 1; rows(k) = i; cols(k) = i + 1; vals(k) = -1.0_dp
            end if
        end do
        call csc_from_coo(N, rows(1:k), cols(1:k), vals(1:k), a, stat)
        call checks%check(stat == STAT_OK, 'the matrix')
        call ls_factor(lu, a, stat, msg)
        call checks%check(stat == STAT_OK, 'its factors')
        cdofs = [(2 * i - 1, i = 1, M)]
    end subroutine build_matrix

    !> What each step needs: NEED columns from a window that moves along the contact-cell
    !> dofs (so groups fall out of use and are dropped, and come back), some none (0);
    !> and up to 4 basis vectors, each of NE columns near the window (some entries 0).
    subroutine random_sequence()
        real(dp) :: r(NEED), rb(4), rc(NE)
        integer :: s, j, k, lo
        do k = 1, NB
            call random_number(rc)
            lo = 1 + mod(3 * k, M - NE)
            bcols(:, k) = [(lo + j - 1, j = 1, NE)]
            if (rc(1) < 0.3_dp) bcols(2, k) = 0
            call random_number(bcoef(:, k))
            bcoef(:, k) = bcoef(:, k) - 0.5_dp
        end do
        do s = 1, STEPS
            lo = 1 + mod(7 * s, M - 20)
            call random_number(r)
            needs(:, s) = lo + int(20 * r)
            where (r < 0.1_dp) needs(:, s) = 0
            call random_number(rb)
            bneed(:, s) = 1 + int(NB * rb)
            where (rb < 0.15_dp) bneed(:, s) = 0
        end do
    end subroutine random_sequence

    !> One step of the sequence on a cache.
    subroutine do_step(zc, s)
        type(zcache_t), intent(inout) :: zc    !! cache
        integer, intent(in) :: s               !! step of the sequence
        integer :: j, k
        call zcache_new_step(zc)
        call zcache_ensure(zc, lu, a, a%val, cdofs, needs(:, s), stat, msg)
        call checks%check(stat == STAT_OK, 'zcache_ensure')
        do j = 1, size(bneed, 1)
            k = bneed(j, s)
            if (k == 0) cycle
            call zcache_basis_ensure(zc, lu, a, a%val, cdofs, k, bcols(:, k), bcoef(:, k), &
                                     stat, msg)
            call checks%check(stat == STAT_OK, 'zcache_basis_ensure')
        end do
    end subroutine do_step

    !> A fresh cache with the budget and the basis.
    subroutine new_cache(zc)
        type(zcache_t), intent(out) :: zc      !! cache
        call zcache_init(zc, N, M, BUDGET, huge(1_i8))   ! Z kept whole (the basis needs it)
        call zcache_basis_init(zc, NB)
    end subroutine new_cache

    !> Run the sequence whole, and again restored from a save after step save_at: the
    !> two caches alike at the end. dropped: at the save, a held basis column reads a
    !> column of Z that is not held.
    subroutine check_restart(save_at, dropped)
        integer, intent(in) :: save_at         !! the step after which the cache is saved
        logical, intent(out) :: dropped        !! the case zcache_basis_reform solves for
        type(zcache_t) :: whole, again
        type(byte_buffer_t) :: buf
        integer :: s, k, e
        character(len=40) :: where
        call new_cache(whole)
        dropped = .false.
        do s = 1, STEPS
            call do_step(whole, s)
            if (s == save_at) then
                call zcache_save(whole, buf)
                do k = 1, NB
                    if (whole%bslot(k) == 0) cycle
                    do e = 1, NE
                        if (bcols(e, k) > 0) then
                            if (whole%slot(bcols(e, k)) == 0) dropped = .true.
                        end if
                    end do
                end do
            end if
        end do
        call new_cache(again)
        buf = buf_from(buf%data(1:buf%n))
        call zcache_load(again, buf)
        call checks%check(.not. buf%bad .and. buf%pos == buf%n, 'the save read back whole')
        call zcache_restore(again, lu, a, a%val, cdofs, stat, msg)
        call checks%check(stat == STAT_OK, 'zcache_restore')
        do s = 1, size(again%bowner)
            k = again%bowner(s)
            if (k == 0) cycle
            call zcache_basis_reform(again, lu, a, a%val, cdofs, s, bcols(:, k), bcoef(:, k), &
                                     stat, msg)
            call checks%check(stat == STAT_OK, 'zcache_basis_reform')
        end do
        call zcache_restore_finish(again)
        do s = save_at + 1, STEPS
            call do_step(again, s)
        end do
        write (where, '(a, i0, a)') 'saved after step ', save_at, ': '
        call checks%check(whole%evicted > 0, trim(where)//'the budget dropped groups')
        call compare(whole, again, trim(where))
    end subroutine check_restart

    !> The two caches alike, bit for bit.
    subroutine compare(x, y, where)
        type(zcache_t), intent(in) :: x, y     !! caches
        character(len=*), intent(in) :: where  !! what the messages start with
        integer :: l, s
        logical :: same
        call checks%check(x%step == y%step .and. x%computed == y%computed .and. &
                          x%evicted == y%evicted .and. x%held == y%held, &
                          where//'the same steps and counters')
        call checks%check(x%bytes == y%bytes .and. x%peak_bytes == y%peak_bytes, &
                          where//'the same bytes and peak')
        call checks%check(all(x%glast == y%glast), where//'the same groups, used at the same steps')
        same = all((x%slot > 0) .eqv. (y%slot > 0))
        do l = 1, M
            if (.not. same) exit
            if (x%slot(l) == 0) cycle
            same = all(x%w(:, x%slot(l)) == y%w(:, y%slot(l))) .and. &
                   all(x%z(x%slot(l))%val == y%z(y%slot(l))%val)
        end do
        call checks%check(same, where//'the same columns of Z and W, bit for bit')
        same = all(x%bslot == y%bslot) .and. all(x%blast == y%blast) .and. &
               size(x%bowner) == size(y%bowner)
        if (same) same = all(x%bowner == y%bowner)
        do s = 1, size(x%bowner)
            if (.not. same) exit
            if (x%bowner(s) == 0) cycle
            same = all(x%zb(:, s) == y%zb(:, s)) .and. all(x%brange(:, s) == y%brange(:, s))
        end do
        call checks%check(same, where//'the same basis columns in the same slots, bit for bit')
    end subroutine compare
end program test_zcache_restore
