//! Eye pass: binned sort-middle software rasterizer (being written).
