"""What only the book's chapters use: figures (`plots`), the Meshcat scenes (`viz`), the
chapters' small helpers (`utils`) and the computations behind their tables.

Layer 8, the top: imports any layer; nothing in the package imports it."""
