//! Penumbra occlusion kernel, paper Eq. 3 (being written).
