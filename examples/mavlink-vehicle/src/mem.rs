//! `memcpy`, `memmove`, `memset`, `memcmp` and their ARM EABI forms (`__aeabi_memcpy4`, ...),
//! a byte at a time: some 200 bytes of flash instead of compiler_builtins' 3.3 kB of word-wise
//! versions (its `memmove` alone is 1.6 kB). The firmware copies little, and small: messages of
//! up to 280 bytes, a mission of 100 items at an upload's end.
//!
//! compiler_builtins defines these symbols weak, so the linker takes these. The loops use
//! volatile accesses so that the compiler cannot turn them back into calls to themselves.

// Raw pointers given by the compiler's calls: the contracts are C's and the EABI's.
#![allow(unsafe_code)]

use core::ptr::{read_volatile, write_volatile};

/// Copies `n` bytes from `src` to `dest`, which may overlap: forwards when `dest` is below
/// `src`, backwards otherwise.
///
/// # Safety
/// `src` readable and `dest` writable for `n` bytes.
#[inline(never)]
unsafe fn copy(dest: *mut u8, src: *const u8, n: usize) {
    if (dest as usize) <= (src as usize) {
        for i in 0..n {
            // SAFETY: i < n, within both ranges.
            unsafe { write_volatile(dest.add(i), read_volatile(src.add(i))) };
        }
    } else {
        for i in (0..n).rev() {
            // SAFETY: as above.
            unsafe { write_volatile(dest.add(i), read_volatile(src.add(i))) };
        }
    }
}

/// Sets `n` bytes at `dest` to `c`.
///
/// # Safety
/// `dest` writable for `n` bytes.
#[inline(never)]
unsafe fn fill(dest: *mut u8, c: u8, n: usize) {
    for i in 0..n {
        // SAFETY: i < n.
        unsafe { write_volatile(dest.add(i), c) };
    }
}

/// # Safety
/// C's `memcpy`.
#[no_mangle]
pub unsafe extern "C" fn memcpy(dest: *mut u8, src: *const u8, n: usize) -> *mut u8 {
    // SAFETY: the caller's contract is `copy`'s.
    unsafe { copy(dest, src, n) };
    dest
}

/// # Safety
/// C's `memmove`.
#[no_mangle]
pub unsafe extern "C" fn memmove(dest: *mut u8, src: *const u8, n: usize) -> *mut u8 {
    // SAFETY: as for `memcpy`.
    unsafe { copy(dest, src, n) };
    dest
}

/// # Safety
/// C's `memset`.
#[no_mangle]
pub unsafe extern "C" fn memset(dest: *mut u8, c: i32, n: usize) -> *mut u8 {
    // SAFETY: the caller's contract is `fill`'s.
    unsafe { fill(dest, c as u8, n) };
    dest
}

/// # Safety
/// C's `memcmp`.
#[no_mangle]
pub unsafe extern "C" fn memcmp(a: *const u8, b: *const u8, n: usize) -> i32 {
    for i in 0..n {
        // SAFETY: i < n, within both ranges.
        let (x, y) = unsafe { (read_volatile(a.add(i)), read_volatile(b.add(i))) };
        if x != y {
            return i32::from(x) - i32::from(y);
        }
    }
    0
}

/// # Safety
/// C's `bcmp`.
#[no_mangle]
pub unsafe extern "C" fn bcmp(a: *const u8, b: *const u8, n: usize) -> i32 {
    // SAFETY: as for `memcmp`.
    unsafe { memcmp(a, b, n) }
}

// The ARM EABI's forms (RTABI §4.3.4). The aligned ones (4, 8) may take the same path: a byte
// copy is right at any alignment. `__aeabi_memset` takes the length before the value.

macro_rules! aeabi_copy {
    ($($name:ident),*) => {$(
        /// # Safety
        /// The EABI's `__aeabi_memcpy`/`__aeabi_memmove` contract (C's `memmove`).
        #[no_mangle]
        pub unsafe extern "C" fn $name(dest: *mut u8, src: *const u8, n: usize) {
            // SAFETY: the caller's contract is `copy`'s.
            unsafe { copy(dest, src, n) }
        }
    )*};
}

aeabi_copy!(
    __aeabi_memcpy,
    __aeabi_memcpy4,
    __aeabi_memcpy8,
    __aeabi_memmove,
    __aeabi_memmove4,
    __aeabi_memmove8
);

macro_rules! aeabi_set {
    ($($name:ident),*) => {$(
        /// # Safety
        /// The EABI's `__aeabi_memset` contract: `dest` writable for `n` bytes.
        #[no_mangle]
        pub unsafe extern "C" fn $name(dest: *mut u8, n: usize, c: i32) {
            // SAFETY: the caller's contract is `fill`'s.
            unsafe { fill(dest, c as u8, n) }
        }
    )*};
}

aeabi_set!(__aeabi_memset, __aeabi_memset4, __aeabi_memset8);

macro_rules! aeabi_clear {
    ($($name:ident),*) => {$(
        /// # Safety
        /// The EABI's `__aeabi_memclr` contract: `dest` writable for `n` bytes.
        #[no_mangle]
        pub unsafe extern "C" fn $name(dest: *mut u8, n: usize) {
            // SAFETY: the caller's contract is `fill`'s.
            unsafe { fill(dest, 0, n) }
        }
    )*};
}

aeabi_clear!(__aeabi_memclr, __aeabi_memclr4, __aeabi_memclr8);
