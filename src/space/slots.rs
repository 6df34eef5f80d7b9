//! A vector reached one element (or one run of elements) at a time: the
//! storage of positions, cells and lists that the members of a Monte
//! Carlo team share ([`crate::mc::parallel`]). Each member holds its own
//! copy of the header (pointer and length) and touches only elements no
//! other member touches meanwhile; an index or a range makes a reference
//! to just those elements, never to the whole vector, so that another
//! member writing elsewhere races with nothing this member reads. (A `Vec`
//! indexed from two threads makes a reference to all its elements each
//! time: Miri's race detector counts that as reading all of them.)
//!
//! Outside a team it is a plain vector: owned, cloned deeply, freed on
//! drop. Whole-vector views ([`Slots::as_slice`], [`Slots::iter`]) are for
//! code that no other thread runs beside.

use std::ops::{Index, IndexMut, Range};
use std::ptr::NonNull;

/// An owned, fixed-length vector reached element by element (see the
/// module docs).
pub struct Slots<T> {
    ptr: NonNull<T>,
    len: usize,
}

// SAFETY: as `Vec<T>`: the elements are owned.
unsafe impl<T: Send> Send for Slots<T> {}
// SAFETY: as `Vec<T>`: shared access gives only `&T`.
unsafe impl<T: Sync> Sync for Slots<T> {}

impl<T> Slots<T> {
    /// Elements.
    #[inline]
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// All elements (not while other threads write some).
    pub fn as_slice(&self) -> &[T] {
        // SAFETY: `ptr` holds `len` initialised elements.
        unsafe { std::slice::from_raw_parts(self.ptr.as_ptr(), self.len) }
    }

    /// All elements, mutable.
    pub fn as_mut_slice(&mut self) -> &mut [T] {
        // SAFETY: `ptr` holds `len` initialised elements, and `&mut self`
        // is the only way to them.
        unsafe { std::slice::from_raw_parts_mut(self.ptr.as_ptr(), self.len) }
    }

    /// Iterates over all elements (not while other threads write some).
    pub fn iter(&self) -> std::slice::Iter<'_, T> {
        self.as_slice().iter()
    }

    /// Iterates over all elements, mutable.
    pub fn iter_mut(&mut self) -> std::slice::IterMut<'_, T> {
        self.as_mut_slice().iter_mut()
    }

    /// Swaps elements `a` and `b`.
    #[inline]
    pub fn swap(&mut self, a: usize, b: usize) {
        assert!(a < self.len && b < self.len, "slot out of range");
        // SAFETY: both in range; `ptr::swap` allows a == b.
        unsafe { std::ptr::swap(self.ptr.as_ptr().add(a), self.ptr.as_ptr().add(b)) }
    }

    #[inline]
    fn check(&self, range: &Range<usize>) {
        assert!(
            range.start <= range.end && range.end <= self.len,
            "slots {range:?} out of 0..{}",
            self.len
        );
    }
}

impl<T> From<Vec<T>> for Slots<T> {
    fn from(v: Vec<T>) -> Self {
        let mut v = std::mem::ManuallyDrop::new(v.into_boxed_slice());
        let len = v.len();
        // A boxed slice's pointer is non-null (dangling when empty).
        let ptr = NonNull::new(v.as_mut_ptr()).expect("a boxed slice's pointer is not null");
        Self { ptr, len }
    }
}

impl<T> Drop for Slots<T> {
    fn drop(&mut self) {
        // SAFETY: made from a boxed slice of `len` elements (`From<Vec>`),
        // and dropped once.
        drop(unsafe {
            Box::from_raw(std::ptr::slice_from_raw_parts_mut(
                self.ptr.as_ptr(),
                self.len,
            ))
        });
    }
}

impl<T: Clone> Clone for Slots<T> {
    fn clone(&self) -> Self {
        self.as_slice().to_vec().into()
    }
}

impl<T: PartialEq> PartialEq for Slots<T> {
    fn eq(&self, o: &Self) -> bool {
        self.as_slice() == o.as_slice()
    }
}

impl<T> Default for Slots<T> {
    fn default() -> Self {
        Vec::new().into()
    }
}

impl<T: std::fmt::Debug> std::fmt::Debug for Slots<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list().entries(self.as_slice()).finish()
    }
}

impl<'a, T> IntoIterator for &'a Slots<T> {
    type Item = &'a T;
    type IntoIter = std::slice::Iter<'a, T>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

impl<'a, T> IntoIterator for &'a mut Slots<T> {
    type Item = &'a mut T;
    type IntoIter = std::slice::IterMut<'a, T>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter_mut()
    }
}

impl<T> Index<usize> for Slots<T> {
    type Output = T;
    #[inline]
    fn index(&self, i: usize) -> &T {
        assert!(i < self.len, "slot {i} out of 0..{}", self.len);
        // SAFETY: in range.
        unsafe { &*self.ptr.as_ptr().add(i) }
    }
}

impl<T> IndexMut<usize> for Slots<T> {
    #[inline]
    fn index_mut(&mut self, i: usize) -> &mut T {
        assert!(i < self.len, "slot {i} out of 0..{}", self.len);
        // SAFETY: in range.
        unsafe { &mut *self.ptr.as_ptr().add(i) }
    }
}

impl<T> Index<Range<usize>> for Slots<T> {
    type Output = [T];
    #[inline]
    fn index(&self, range: Range<usize>) -> &[T] {
        self.check(&range);
        // SAFETY: in range.
        unsafe { std::slice::from_raw_parts(self.ptr.as_ptr().add(range.start), range.len()) }
    }
}

impl<T> IndexMut<Range<usize>> for Slots<T> {
    #[inline]
    fn index_mut(&mut self, range: Range<usize>) -> &mut [T] {
        self.check(&range);
        // SAFETY: in range.
        unsafe { std::slice::from_raw_parts_mut(self.ptr.as_ptr().add(range.start), range.len()) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Index, range, swap, clone and drop behave as a `Vec`'s (under Miri
    /// too: no leak, no double free, no use after free).
    #[test]
    fn slots_behave_as_a_vec() {
        let mut s: Slots<String> = (0..6).map(|k| k.to_string()).collect::<Vec<_>>().into();
        assert_eq!(s.len(), 6);
        s[2].push('x');
        s.swap(0, 5);
        assert_eq!(&s[0..3], &["5".to_string(), "1".into(), "2x".into()]);
        let c = s.clone();
        s[1] = "one".into();
        assert_eq!(c[1], "1");
        assert_eq!(
            s.iter().map(|t| t.len()).sum::<usize>(),
            1 + 3 + 2 + 1 + 1 + 1
        );
        let empty: Slots<u8> = Slots::default();
        assert!(empty.is_empty() && empty.as_slice().is_empty());
    }

    #[test]
    #[should_panic(expected = "out of")]
    fn an_index_out_of_range_panics() {
        let s: Slots<u8> = vec![1, 2].into();
        let _ = s[2];
    }
}
