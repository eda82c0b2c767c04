"""The file wrapper that `test_faults.py`'s failing writes share: it hands every call
to the real temporary file of `io._atomic`, so a subclass changes `write` alone (a disk
that fills, a process killed mid-write). A module of its own because the kill runs in a
child process (`test_faults.KILLER`), which imports it from here."""

from io import RawIOBase


class Passthrough(RawIOBase):
    """The real file `f` behind a raw, writable, seekable stream; subclasses fail in
    `write`. Trap: `torch.save` and `np.save` seek and tell on what they write into, so
    those must reach the real file too."""

    def __init__(self, f):
        self.f = f

    def writable(self):
        return True

    def seekable(self):
        return self.f.seekable()

    def tell(self):
        return self.f.tell()

    def seek(self, *a):
        return self.f.seek(*a)

    def write(self, b):
        return self.f.write(b)
