//! libhdf5 opens its files without `O_CLOEXEC` and locks them with `flock`. A child
//! process started while a recording is open (a supervisor's process, a test's
//! `python3`) would inherit the descriptor and, with it, the lock: the file then stays
//! locked until that child exits, and a reader opening it meanwhile is refused
//! ("unable to lock file, errno = 11"). Marking the descriptor close-on-exec right
//! after the open keeps it in this process.

use hdf5_sys::h5f::H5Fget_vfd_handle;
use hdf5_sys::h5p::H5P_DEFAULT;
use std::os::raw::{c_int, c_void};

/// Mark `file`'s descriptor close-on-exec. Only the default (sec2) driver hands out a
/// POSIX descriptor, and that is the only one opened here; if libhdf5 does not give
/// one, nothing is changed (the file still works; only the inheritance remains).
pub(crate) fn keep_from_children(file: &hdf5::File) {
    hdf5::sync::sync(|| {
        let mut handle: *mut c_void = std::ptr::null_mut();
        // SAFETY: `file.id()` is an open file id (the `File` is borrowed); for the sec2
        // driver libhdf5 sets `handle` to the address of the `int` descriptor it keeps
        // in its own file struct, valid while the file is open, which it is here.
        let fd = unsafe {
            if H5Fget_vfd_handle(file.id(), H5P_DEFAULT, &mut handle) < 0 || handle.is_null() {
                return;
            }
            *(handle as *const c_int)
        };
        // SAFETY: plain fcntl calls on a descriptor this process owns.
        unsafe {
            let flags = libc::fcntl(fd, libc::F_GETFD);
            if flags >= 0 {
                libc::fcntl(fd, libc::F_SETFD, flags | libc::FD_CLOEXEC);
            }
        }
    })
}
