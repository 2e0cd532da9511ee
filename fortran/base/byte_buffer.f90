!> A growing byte buffer that numbers, arrays and text are packed into and read back
!> from, bit for bit (the payload of a checkpoint). Every array is preceded by its
!> element count; a read checks it against the size of the array it fills, and a read
!> past the end or of the wrong count marks the buffer `bad` instead of failing.
module byte_buffer
    use kinds, only: dp, i8
    implicit none
    private

    !> Bytes written (put) or being read (get).
    type, public :: byte_buffer_t
        character(len=:), allocatable :: data       !! the bytes (capacity len(data))
        integer(i8) :: n = 0                        !! bytes written
        integer(i8) :: pos = 0                      !! bytes read
        logical :: bad = .false.                    !! a read did not match what was written
    end type byte_buffer_t

    !> Append a value: integer(i8), real(dp), or a 1D / 2D array of integers or reals.
    interface buf_put
        module procedure put_i8, put_real, put_ints, put_reals, put_ints2, put_reals2
    end interface buf_put

    !> Read the next value into a variable of the same kind and size as was written.
    interface buf_get
        module procedure get_i8, get_real, get_ints, get_reals, get_ints2, get_reals2
    end interface buf_get

    public :: buf_put, buf_get, buf_put_text, buf_get_text, buf_from

contains

    !> A buffer to read `bytes` from.
    pure function buf_from(bytes) result(b)
        character(len=*), intent(in) :: bytes   !! the bytes
        type(byte_buffer_t) :: b
        b%data = bytes
        b%n = len(bytes, i8)
        b%pos = 0
    end function buf_from

    !> Append raw bytes (the buffer doubles when full).
    pure subroutine put_bytes(b, s)
        type(byte_buffer_t), intent(inout) :: b   !! buffer
        character(len=*), intent(in) :: s         !! bytes to append
        character(len=:), allocatable :: grown
        integer(i8) :: need
        if (.not. allocated(b%data)) allocate (character(len=4096) :: b%data)
        need = b%n + len(s, i8)
        if (need > len(b%data, i8)) then
            allocate (character(len=max(need, 2_i8 * len(b%data, i8))) :: grown)
            grown(1:b%n) = b%data(1:b%n)
            call move_alloc(grown, b%data)
        end if
        b%data(b%n + 1:need) = s
        b%n = need
    end subroutine put_bytes

    !> Whether nb more bytes can be read; marks the buffer bad otherwise (a subroutine,
    !> not a function: it changes b).
    pure subroutine check_readable(b, nb, ok)
        type(byte_buffer_t), intent(inout) :: b   !! buffer
        integer(i8), intent(in) :: nb             !! bytes to read
        logical, intent(out) :: ok                !! they can be read
        ok = .not. b%bad .and. nb >= 0 .and. b%pos + nb <= b%n
        if (.not. ok) b%bad = .true.
    end subroutine check_readable

    !> Append a 64-bit integer (its 8 bytes).
    pure subroutine put_i8(b, x)
        type(byte_buffer_t), intent(inout) :: b   !! buffer
        integer(i8), intent(in) :: x              !! value
        call put_bytes(b, transfer(x, repeat(' ', 8)))
    end subroutine put_i8

    !> Append a real (its 8 bytes).
    pure subroutine put_real(b, x)
        type(byte_buffer_t), intent(inout) :: b   !! buffer
        real(dp), intent(in) :: x                 !! value
        call put_bytes(b, transfer(x, repeat(' ', 8)))
    end subroutine put_real

    !> Append an integer array (its count first).
    pure subroutine put_ints(b, x)
        type(byte_buffer_t), intent(inout) :: b   !! buffer
        integer, intent(in) :: x(:)               !! values
        call put_i8(b, size(x, kind=i8))
        if (size(x) > 0) call put_bytes(b, transfer(int(x, i8), repeat(' ', 8 * size(x))))
    end subroutine put_ints

    !> Append a real array (its count first).
    pure subroutine put_reals(b, x)
        type(byte_buffer_t), intent(inout) :: b   !! buffer
        real(dp), intent(in) :: x(:)              !! values
        call put_i8(b, size(x, kind=i8))
        if (size(x) > 0) call put_bytes(b, transfer(x, repeat(' ', 8 * size(x))))
    end subroutine put_reals

    !> Append a 2D integer array (column order, its count first).
    pure subroutine put_ints2(b, x)
        type(byte_buffer_t), intent(inout) :: b   !! buffer
        integer, intent(in) :: x(:, :)            !! values
        call put_ints(b, reshape(x, [size(x)]))
    end subroutine put_ints2

    !> Append a 2D real array (column order, its count first).
    pure subroutine put_reals2(b, x)
        type(byte_buffer_t), intent(inout) :: b   !! buffer
        real(dp), intent(in) :: x(:, :)           !! values
        call put_reals(b, reshape(x, [size(x)]))
    end subroutine put_reals2

    !> Append a text (its length first).
    pure subroutine buf_put_text(b, s)
        type(byte_buffer_t), intent(inout) :: b   !! buffer
        character(len=*), intent(in) :: s         !! text
        call put_i8(b, len(s, i8))
        call put_bytes(b, s)
    end subroutine buf_put_text

    !> Read a 64-bit integer (0 when the buffer is bad).
    pure subroutine get_i8(b, x)
        type(byte_buffer_t), intent(inout) :: b   !! buffer
        integer(i8), intent(out) :: x             !! value
        logical :: ok
        x = 0
        call check_readable(b, 8_i8, ok)
        if (.not. ok) return
        x = transfer(b%data(b%pos + 1:b%pos + 8), x)
        b%pos = b%pos + 8
    end subroutine get_i8

    !> Read a real (0 when the buffer is bad).
    pure subroutine get_real(b, x)
        type(byte_buffer_t), intent(inout) :: b   !! buffer
        real(dp), intent(out) :: x                !! value
        logical :: ok
        x = 0.0_dp
        call check_readable(b, 8_i8, ok)
        if (.not. ok) return
        x = transfer(b%data(b%pos + 1:b%pos + 8), x)
        b%pos = b%pos + 8
    end subroutine get_real

    !> Read the count of an array and check it against `expected`.
    pure subroutine get_count(b, expected)
        type(byte_buffer_t), intent(inout) :: b   !! buffer
        integer, intent(in) :: expected           !! count the reader expects
        integer(i8) :: k
        logical :: ok
        call get_i8(b, k)
        if (k /= expected) b%bad = .true.
        if (.not. b%bad) call check_readable(b, 8_i8 * k, ok)
    end subroutine get_count

    !> Read an integer array of the size written.
    pure subroutine get_ints(b, x)
        type(byte_buffer_t), intent(inout) :: b   !! buffer
        integer, intent(out) :: x(:)              !! values
        integer(i8) :: nb
        x = 0
        call get_count(b, size(x))
        if (b%bad .or. size(x) == 0) return
        nb = 8_i8 * size(x)
        x = int(transfer(b%data(b%pos + 1:b%pos + nb), 0_i8, size(x)))
        b%pos = b%pos + nb
    end subroutine get_ints

    !> Read a real array of the size written.
    pure subroutine get_reals(b, x)
        type(byte_buffer_t), intent(inout) :: b   !! buffer
        real(dp), intent(out) :: x(:)             !! values
        integer(i8) :: nb
        x = 0.0_dp
        call get_count(b, size(x))
        if (b%bad .or. size(x) == 0) return
        nb = 8_i8 * size(x)
        x = transfer(b%data(b%pos + 1:b%pos + nb), 0.0_dp, size(x))
        b%pos = b%pos + nb
    end subroutine get_reals

    !> Read a 2D integer array of the shape written.
    pure subroutine get_ints2(b, x)
        type(byte_buffer_t), intent(inout) :: b   !! buffer
        integer, intent(out) :: x(:, :)           !! values
        integer :: flat(size(x))
        call get_ints(b, flat)
        x = reshape(flat, shape(x))
    end subroutine get_ints2

    !> Read a 2D real array of the shape written.
    pure subroutine get_reals2(b, x)
        type(byte_buffer_t), intent(inout) :: b   !! buffer
        real(dp), intent(out) :: x(:, :)          !! values
        real(dp) :: flat(size(x))
        call get_reals(b, flat)
        x = reshape(flat, shape(x))
    end subroutine get_reals2

    !> Read a text into s (blank-padded; bad if it is longer than s).
    pure subroutine buf_get_text(b, s)
        type(byte_buffer_t), intent(inout) :: b   !! buffer
        character(len=*), intent(out) :: s        !! text
        integer(i8) :: k
        logical :: ok
        s = ''
        call get_i8(b, k)
        if (k > len(s, i8)) b%bad = .true.
        call check_readable(b, k, ok)
        if (.not. ok) return
        s = b%data(b%pos + 1:b%pos + k)
        b%pos = b%pos + k
    end subroutine buf_get_text
end module byte_buffer
