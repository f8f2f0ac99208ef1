//! An independent, literal transcription of ../shared/docs/RBSM-VISIBILITY.md (§1–§5), written from
//! the document and not from `sism::algorithms::rbsm::visibility`, checked against that module (the
//! scalar functions the lookup kernel runs) on random fragments and hand-made texel patterns; plus the
//! paper's properties on real renders.
//!
//! The transcription keeps the document's own vocabulary: `r` and `g` as the fractions 0, .25, .5,
//! .75; lit tests as 0/1 numbers; walks as in the §2 pseudocode.

use sism::algorithms::rbsm::visibility::{self, DepthTexels, Function, Settings};

/// A test map: `w × h` depths, −∞ outside.
struct Grid {
    w: i64,
    h: i64,
    d: Vec<f32>,
}

impl DepthTexels for Grid {
    fn depth(&self, x: i64, y: i64) -> f32 {
        if x < 0 || y < 0 || x >= self.w || y >= self.h {
            f32::NEG_INFINITY
        } else {
            self.d[(y * self.w + x) as usize]
        }
    }
    fn inside(&self, x: i64, y: i64) -> bool {
        x >= 0 && y >= 0 && x < self.w && y < self.h
    }
}

// ------------------------------------------------------------------------------------------------
// The transcription.

struct Oracle<'a> {
    map: &'a Grid,
    max_search: i32,
    eps: f32,
}

/// lit(t, z) ⇔ z ≤ D(t), as 1 or 0.
fn lit(m: &Grid, x: i64, y: i64, z: f32) -> u8 {
    (z <= m.depth(x, y)) as u8
}

struct Frag {
    t0: (i64, i64),
    px: f32,
    py: f32,
    z: f32,
    c: u8,
    b: u8,
    r: f32,
    g: f32,
}

impl Oracle<'_> {
    /// §1.
    fn frag(&self, u: f32, v: f32, z: f32, speck: bool) -> Frag {
        let m = self.map;
        let t0 = (u.floor() as i64, v.floor() as i64);
        let (px, py) = (u - u.floor(), v - v.floor());
        let c = lit(m, t0.0, t0.1, z);
        let offs = [(-1i64, 0i64), (1, 0), (0, 1), (0, -1)]; // L R B T
        let mut dk = [0u8; 4];
        for (k, o) in offs.iter().enumerate() {
            let q = (t0.0 + o.0, t0.1 + o.1);
            let mut n = lit(m, q.0, q.1, z);
            if speck {
                let neigh: Vec<u8> = offs.iter().map(|p| lit(m, q.0 + p.0, q.1 + p.1, z)).collect();
                if c == 0 && n == 1 && neigh.iter().all(|&x| x == 0) {
                    n = 0;
                }
                if c == 1 && n == 0 && neigh.iter().all(|&x| x == 1) {
                    n = 1;
                }
            }
            dk[k] = (n != c) as u8;
        }
        Frag {
            t0,
            px,
            py,
            z,
            c,
            b: 1 - c,
            r: (2.0 * dk[0] as f32 + dk[1] as f32) / 4.0,
            g: (2.0 * dk[2] as f32 + dk[3] as f32) / 4.0,
        }
    }

    fn fx(&self, f: &Frag) -> Vec<(i64, i64)> {
        let mut v = vec![];
        if f.r == 0.5 || f.r == 0.75 {
            v.push((-1, 0));
        }
        if f.r == 0.25 || f.r == 0.75 {
            v.push((1, 0));
        }
        v
    }
    fn fy(&self, f: &Frag) -> Vec<(i64, i64)> {
        let mut v = vec![];
        if f.g == 0.5 || f.g == 0.75 {
            v.push((0, 1));
        }
        if f.g == 0.25 || f.g == 0.75 {
            v.push((0, -1));
        }
        v
    }

    /// §2 `alpha(dir)`.
    fn alpha(&self, f: &Frag, dir: (i64, i64), rsmss: bool) -> i32 {
        let m = self.map;
        let vertical = dir.0 == 0;
        if vertical && f.r == 0.0 && f.g != 0.0 {
            return -1;
        }
        if !vertical && f.r != 0.0 && f.g == 0.0 {
            return -1;
        }
        let mut k = 1;
        let mut t = (f.t0.0 + dir.0, f.t0.1 + dir.1);
        let mut zz = f.z;
        for _ in 0..self.max_search {
            if f.b == 0 && (zz - m.depth(t.0, t.1)).abs() < self.eps {
                zz -= self.eps;
            }
            let lt = lit(m, t.0, t.1, zz);
            if lt != f.c {
                if !rsmss {
                    return k;
                }
                let ok = [(-1, 0), (1, 0), (0, 1), (0, -1)]
                    .iter()
                    .any(|o: &(i64, i64)| lit(m, t.0 + o.0, t.1 + o.1, zz) == lt);
                return if ok { k } else { -k };
            }
            let p = if vertical { self.fx(f) } else { self.fy(f) };
            let mut zl = zz;
            let mut keep = false;
            for mm in p {
                if rsmss && f.b == 1 && (zl - m.depth(t.0 + mm.0, t.1 + mm.1)).abs() < self.eps {
                    zl -= self.eps;
                }
                if lit(m, t.0 + mm.0, t.1 + mm.1, zl) != f.c {
                    keep = true;
                    break;
                }
            }
            if !keep {
                return -k;
            }
            k += 1;
            t = (t.0 + dir.0, t.1 + dir.1);
            if rsmss && f.b == 1 {
                zz = zl;
            }
        }
        -k
    }

    /// §2 normalisation.
    fn norm(&self, am: i32, ap: i32, p: f32) -> f32 {
        if am < 0 && ap < 0 {
            return -1.0;
        }
        let lh = (am.abs() + ap.abs() - 1).min(self.max_search) as f32;
        let po = if am == ap {
            p.min(1.0 - p)
        } else if am > ap {
            1.0 - p
        } else {
            p
        };
        let d = 1.0 - (am.max(ap) as f32) / lh + po / lh;
        if am > 0 && ap > 0 {
            2.0 * d - 3.0
        } else {
            d
        }
    }

    fn n_xy(&self, f: &Frag, rsmss: bool) -> (f32, f32) {
        let nx = self.norm(self.alpha(f, (-1, 0), rsmss), self.alpha(f, (1, 0), rsmss), f.px);
        let ny = self.norm(self.alpha(f, (0, -1), rsmss), self.alpha(f, (0, 1), rsmss), f.py);
        (nx, ny)
    }

    fn deltas(&self, f: &Frag) -> (f32, f32) {
        let dx = if f.r == 0.5 {
            f.px
        } else if f.r == 0.25 {
            1.0 - f.px
        } else {
            0.0
        };
        let dy = if f.g == 0.5 {
            1.0 - f.py
        } else if f.g == 0.25 {
            f.py
        } else {
            0.0
        };
        (dx, dy)
    }

    fn shadowed(&self, f: &Frag, x: i64, y: i64) -> bool {
        lit(self.map, x, y, f.z) == 0
    }

    /// §3.
    fn smsr(&self, u: f32, v: f32, z: f32) -> f32 {
        let f = self.frag(u, v, z, false);
        if f.c == 0 {
            return 0.0;
        }
        if f.r == 0.0 && f.g == 0.0 {
            return 1.0;
        }
        let (nx, ny) = self.n_xy(&f, false);
        let (dx, dy) = self.deltas(&f);
        if nx == -1.0 && ny == -1.0 {
            return 1.0;
        }
        if nx <= -2.0 || ny <= -2.0 {
            return 0.0;
        }
        if f.r == 0.75 || f.g == 0.75 {
            return 0.0;
        }
        let r5 = if nx <= dy { 1.0f32 } else { 0.0 };
        let r6 = if ny <= dx { 1.0f32 } else { 0.0 };
        if f.r > 0.0 && f.g > 0.0 {
            let (i, j) = f.t0;
            let qx = if f.r == 0.5 { (i + 1, j) } else { (i - 1, j) };
            let hh = self.shadowed(&f, qx.0, qx.1 + 1) || self.shadowed(&f, qx.0, qx.1 - 1);
            let qy = if f.g == 0.5 { (i, j - 1) } else { (i, j + 1) };
            let vv = self.shadowed(&f, qy.0 - 1, qy.1) || self.shadowed(&f, qy.0 + 1, qy.1);
            if hh && vv {
                return r5.min(r6);
            }
            if !hh && vv {
                return r6;
            }
            return r5;
        }
        if f.g > 0.0 {
            r5
        } else {
            r6
        }
    }

    /// §4 (ReallyOptimized).
    fn rsmss(&self, u: f32, v: f32, z: f32) -> f32 {
        let f = self.frag(u, v, z, true);
        let c01 = |x: f32| x.clamp(0.0, 1.0);
        if f.r == 0.0 && f.g == 0.0 {
            return f.c as f32;
        }
        if f.r == 0.75 && f.g == 0.75 {
            return f.b as f32;
        }
        let (nx, ny) = self.n_xy(&f, true);
        let (dx, dy) = self.deltas(&f);
        let (px, py) = (f.px, f.py);
        let ay = if f.g == 0.0 {
            f32::INFINITY
        } else if nx < -2.0 {
            dy
        } else {
            c01(1.0 + dy - nx)
        };
        let ax = if f.r == 0.0 {
            f32::INFINITY
        } else if ny < -2.0 {
            dx
        } else {
            c01(1.0 + dx - ny)
        };
        let (i, j) = f.t0;
        let sh = |x: i64, y: i64| self.shadowed(&f, x, y);
        if f.b == 0 {
            if nx == -1.0 && ny == -1.0 {
                return 1.0;
            }
            let mut q = (i, j);
            if nx <= -2.0 && ny <= -2.0 && f.r != 0.0 && f.g != 0.0 && (f.r == 0.75 || f.g == 0.75) {
                let sx = if f.r == 0.5 {
                    1
                } else if f.r == 0.25 {
                    -1
                } else {
                    3
                };
                let sy = if f.g == 0.5 {
                    -1
                } else if f.g == 0.25 {
                    1
                } else {
                    -3
                };
                q = (i + sx, j + sy);
                let both = if f.r == 0.75 {
                    sh(q.0 - 1, q.1) && sh(q.0 + 1, q.1)
                } else {
                    sh(q.0, q.1 + 1) && sh(q.0, q.1 - 1)
                };
                if both {
                    let nxp = (nx + 4.0) / 2.0;
                    let nyp = (ny + 4.0) / 2.0;
                    if f.r == 0.75 {
                        return c01(px - nyp + 1.0).min(c01(2.0 - px - nyp)).min(py);
                    }
                    return c01(py - nxp + 1.0).min(c01(2.0 - py - nxp)).min(px);
                }
            }
            let single = |x: f32| x == 0.25 || x == 0.5;
            if f.g == 0.75 && single(f.r) {
                let s = if f.r == 0.5 { (1, 0) } else { (-1, 0) };
                let (mut p, mut n);
                loop {
                    q = (q.0 + s.0, q.1 + s.1);
                    p = sh(q.0, q.1 + 1);
                    n = sh(q.0, q.1 - 1);
                    if !(p && n) || sh(q.0, q.1) {
                        break;
                    }
                }
                if !p && !n {
                    return c01(1.0 - nx);
                }
                return (if p { c01(2.0 - py - nx) } else { dx }).min(if n {
                    c01(1.0 + py - nx)
                } else {
                    dx
                });
            }
            if f.r == 0.75 && single(f.g) {
                let s = if f.g == 0.5 { (0, -1) } else { (0, -2) };
                let (mut p, mut n);
                loop {
                    q = (q.0 + s.0, q.1 + s.1);
                    p = sh(q.0 - 1, q.1);
                    n = sh(q.0 + 1, q.1);
                    if !(p && n) || sh(q.0, q.1) {
                        break;
                    }
                }
                if !p && !n {
                    return c01(1.0 - ny);
                }
                return (if n { c01(2.0 - px - ny) } else { 1.0 - py }).min(if p {
                    c01(1.0 + px - ny)
                } else {
                    1.0 - py
                });
            }
            if (f.r == 0.75 && f.g == 0.0) || (f.g == 0.75 && f.r == 0.0) {
                let vertical = f.r == 0.75;
                // Flags: a = L (or T), b = R (or B); the walk along v (or u).
                let (dir, a_off, b_off, p, n) = if vertical {
                    ((0i64, 1i64), (-1i64, 0i64), (1i64, 0i64), px, ny)
                } else {
                    ((1, 0), (0, -1), (0, 1), py, nx)
                };
                let (mut ap, mut bp, mut am, mut bm) = (true, true, true, true);
                let mut up = (i, j);
                let mut dn = (i, j);
                let (mut wu, mut wd) = (true, true);
                while ap && bp && am && bm && (wu || wd) {
                    if wu {
                        up = (up.0 + dir.0, up.1 + dir.1);
                        if sh(up.0, up.1) {
                            wu = false;
                            ap = true;
                            bp = true;
                        } else {
                            ap = sh(up.0 + a_off.0, up.1 + a_off.1);
                            bp = sh(up.0 + b_off.0, up.1 + b_off.1);
                        }
                    }
                    if wd {
                        dn = (dn.0 - dir.0, dn.1 - dir.1);
                        if sh(dn.0, dn.1) {
                            wd = false;
                            am = true;
                            bm = true;
                        } else {
                            am = sh(dn.0 + a_off.0, dn.1 + a_off.1);
                            bm = sh(dn.0 + b_off.0, dn.1 + b_off.1);
                        }
                    }
                }
                let bmiss = !bp || !bm;
                let amiss = !ap || !am;
                if n <= -2.0 {
                    let np = (n + 4.0) / 2.0;
                    let a1 = c01(p - np + 1.0);
                    let a2 = c01(2.0 - p - np);
                    return if bmiss {
                        a1
                    } else if amiss {
                        a2
                    } else {
                        a1.min(a2)
                    };
                }
                if (!ap && !bp) || (!am && !bm) {
                    return c01(1.0 - n);
                }
                return if bmiss { c01(1.0 + p - n) } else { c01(2.0 - p - n) };
            }
            return ax.min(ay);
        }
        // Exiting.
        let sy = if f.g == 0.25 { 1.0 - py } else { py };
        let sx = if f.r == 0.25 { px } else { 1.0 - px };
        let s3 = |n: f32, a: f32, c: f32| if n < -2.0 { a } else { c };
        if f.r == 0.75 && f.g == 0.0 {
            let mut l = sh(i - 2, j);
            let mut rr = sh(i + 2, j);
            if !l && !rr {
                let mut k = 1;
                'scan: loop {
                    for row in [j + k, j - k] {
                        l = sh(i - 1, row + 1) || sh(i - 1, row - 1);
                        rr = sh(i + 1, row + 1) || sh(i + 1, row - 1);
                        if l || rr {
                            break 'scan;
                        }
                    }
                    k += 1;
                }
            }
            if l && rr {
                return c01(ny);
            }
            if !l {
                return s3(ny, 1.0 - px, c01(ny - px));
            }
            return s3(ny, px, c01(ny - 1.0 + px));
        }
        if f.r == 0.75 {
            let dv = if f.g == 0.5 { -1 } else { 1 };
            let mut q = (i, j + dv);
            let l = sh(q.0 - 1, q.1);
            let rr = sh(q.0 + 1, q.1);
            if l && rr {
                return c01(ny);
            }
            if l || rr {
                let a = if l { sy } else { s3(ny, 1.0 - px, c01(ny - px)) };
                let c = if rr { sy } else { s3(ny, px, c01(ny - 1.0 + px)) };
                return a.max(c);
            }
            // The document's walk "until q is lit" never ends off the map (outside is shadowed): stop
            // at the first texel outside.
            while sh(q.0, q.1) && self.map.inside(q.0, q.1) {
                q.1 += dv;
            }
            let l = sh(i - 1, q.1 + 1) || sh(i - 1, q.1 - 1);
            let rr = sh(i + 1, q.1 + 1) || sh(i + 1, q.1 - 1);
            if l && rr {
                return c01(ny);
            }
            return (if l { px } else { 1.0 - px }).max(sy);
        }
        if f.g == 0.75 && f.r == 0.0 {
            let mut t = sh(i - 1, j - 1) || sh(i + 1, j - 1);
            let mut bb = sh(i - 1, j + 1) || sh(i + 1, j + 1);
            if !t && !bb {
                let mut k = 1;
                'cols: loop {
                    for col in [i + k, i - k] {
                        t = sh(col - 1, j - 1) || sh(col + 1, j - 1);
                        bb = sh(col - 1, j + 1) || sh(col + 1, j + 1);
                        if t || bb {
                            break 'cols;
                        }
                    }
                    k += 1;
                }
            }
            if t && bb {
                return c01(nx);
            }
            if !t {
                return s3(nx, 1.0 - py, c01(nx - py));
            }
            return s3(nx, py, c01(nx - 1.0 + py));
        }
        if f.g == 0.75 {
            let du = if f.r == 0.5 { 1 } else { -1 };
            let mut q = (i + du, j);
            let bb = sh(q.0, q.1 + 1);
            let t = sh(q.0, q.1 - 1);
            if bb && t {
                return c01(nx);
            }
            if bb || t {
                let a = if t { sx } else { s3(nx, 1.0 - py, c01(nx - py)) };
                let c = if bb { sx } else { s3(nx, py, c01(nx - 1.0 + py)) };
                return a.max(c);
            }
            while sh(q.0, q.1) && self.map.inside(q.0, q.1) {
                q.0 += du;
            }
            let t = sh(q.0 - 1, j - 1) || sh(q.0 + 1, j - 1);
            let bb = sh(q.0 - 1, j + 1) || sh(q.0 + 1, j + 1);
            if t && bb {
                return c01(nx);
            }
            return (if t { py } else { 1.0 - py }).max(sx);
        }
        1.0 - ax.min(ay)
    }

    /// §5 (2017): (K+1)² taps, sum / count.
    fn rpcf(&self, u: f32, v: f32, z: f32, rsmss: bool, k: u32, p: f32) -> f32 {
        let mut offs = vec![];
        let mut w = -p;
        while w <= p {
            offs.push(w);
            w += 2.0 * p / k as f32;
        }
        let mut sum = 0.0f32;
        for &hh in &offs {
            for &ww in &offs {
                sum += if rsmss {
                    self.rsmss(u + ww, v + hh, z)
                } else {
                    self.smsr(u + ww, v + hh, z)
                };
            }
        }
        sum / (offs.len() * offs.len()) as f32
    }
}

// ------------------------------------------------------------------------------------------------
// Random maps: a sloped receiver plane (its own depths in the map, so the ε rule triggers) under
// random rectangular and triangular occluders.

struct Rng(u64);
impl Rng {
    fn f(&mut self) -> f32 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 40) as f32) / (1u64 << 24) as f32
    }
    fn range(&mut self, a: f32, b: f32) -> f32 {
        a + (b - a) * self.f()
    }
}

/// A random map and the receiver plane's depth function.
fn random_map(rng: &mut Rng) -> (Grid, [f32; 3]) {
    let (w, h) = (24 + (rng.f() * 24.0) as i64, 24 + (rng.f() * 24.0) as i64);
    // Receiver plane: depth 0.5 + a x + b y, slopes up to ~ε per texel and beyond.
    let scale = [1e-6, 2.5e-5, 1e-4, 1e-3][(rng.f() * 4.0) as usize % 4];
    let plane = [0.5, rng.range(-3.0, 3.0) * scale, rng.range(-3.0, 3.0) * scale];
    let mut d: Vec<f32> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| plane[0] + plane[1] * (x as f32 + 0.5) + plane[2] * (y as f32 + 0.5))
        .collect();
    let occluders = (rng.f() * 6.0) as usize;
    for _ in 0..occluders {
        let depth = rng.range(0.1, 0.45);
        let (x0, y0) = (rng.range(-4.0, w as f32), rng.range(-4.0, h as f32));
        let (sx, sy) = (rng.range(1.0, 14.0), rng.range(1.0, 14.0));
        let tri = rng.f() < 0.5;
        let slope = rng.range(-0.1, 0.1) * scale * 10.0;
        for y in 0..h {
            for x in 0..w {
                let (fx, fy) = ((x as f32 + 0.5 - x0) / sx, (y as f32 + 0.5 - y0) / sy);
                let inside = fx >= 0.0 && fy >= 0.0 && fx <= 1.0 && fy <= 1.0 && (!tri || fx + fy <= 1.0);
                if inside {
                    let k = (y * w + x) as usize;
                    d[k] = d[k].min(depth + slope * x as f32);
                }
            }
        }
    }
    // A few single-texel specks of each kind.
    for _ in 0..(rng.f() * 4.0) as usize {
        let k = (rng.f() * (w * h) as f32) as usize % (w * h) as usize;
        d[k] = if rng.f() < 0.5 { 0.2 } else { f32::INFINITY };
    }
    (Grid { w, h, d }, plane)
}

#[test]
fn the_functions_match_an_independent_transcription_on_random_fragments() {
    let mut rng = Rng(0x5EED_1234);
    let mut checked = 0u64;
    let mut flagged = 0u64;
    let mut mismatches = Vec::new();
    for map_no in 0..600 {
        let (grid, plane) = random_map(&mut rng);
        let max_search = if map_no % 5 == 0 { 4 } else { 16 };
        let eps = 2.5e-5;
        let settings = Settings {
            max_search,
            epsilon: eps,
        };
        let oracle = Oracle {
            map: &grid,
            max_search,
            eps,
        };
        for _ in 0..60 {
            let u = rng.range(-1.0, grid.w as f32 + 1.0);
            let v = rng.range(-1.0, grid.h as f32 + 1.0);
            // On the receiver plane, within a few ε of it.
            let z = plane[0] + plane[1] * u + plane[2] * v + rng.range(-3.0, 3.0) * eps;
            let cases: [(&str, f32, f32); 5] = [
                (
                    "smsr",
                    visibility::visibility(&grid, u, v, z, Function::Smsr, &settings).0,
                    oracle.smsr(u, v, z),
                ),
                (
                    "rsmss",
                    visibility::visibility(&grid, u, v, z, Function::Rsmss, &settings).0,
                    oracle.rsmss(u, v, z),
                ),
                (
                    "rpcf-smsr 3x3",
                    visibility::rpcf(&grid, u, v, z, Function::Smsr, &settings, 2, 1.0).0,
                    oracle.rpcf(u, v, z, false, 2, 1.0),
                ),
                (
                    "rpcf-rsmss 3x3",
                    visibility::rpcf(&grid, u, v, z, Function::Rsmss, &settings, 2, 1.0).0,
                    oracle.rpcf(u, v, z, true, 2, 1.0),
                ),
                (
                    "rpcf-rsmss K=3 P=1.5",
                    visibility::rpcf(&grid, u, v, z, Function::Rsmss, &settings, 3, 1.5).0,
                    oracle.rpcf(u, v, z, true, 3, 1.5),
                ),
            ];
            if visibility::visibility(&grid, u, v, z, Function::Rsmss, &settings)
                .1
                .flagged
            {
                flagged += 1;
            }
            for (name, got, want) in cases {
                checked += 1;
                if got.to_bits() != want.to_bits() && mismatches.len() < 10 {
                    mismatches.push(format!("map {map_no} {name} at ({u}, {v}, {z}): {got} vs {want}"));
                }
            }
        }
    }
    eprintln!("{checked} evaluations, {flagged} fragments with a discontinuity");
    assert!(checked >= 180_000, "{checked}");
    assert!(
        flagged > 5_000,
        "the random maps must exercise the walks: {flagged}"
    );
    assert!(mismatches.is_empty(), "{}", mismatches.join("\n"));
}

/// A map from rows of characters: `#` occluder (depth 0.2), `.` receiver level (0.5).
fn pattern(rows: &[&str]) -> Grid {
    let h = rows.len() as i64;
    let w = rows[0].len() as i64;
    let d = rows
        .iter()
        .flat_map(|r| r.chars().map(|c| if c == '#' { 0.2 } else { 0.5 }))
        .collect();
    Grid { w, h, d }
}

#[test]
fn hand_made_patterns_cover_every_case_and_match() {
    // Edges, corners, corridors, single specks, U and L shapes, runs closed at both ends.
    let patterns: &[&[&str]] = &[
        &[
            "........", "........", "...####.", "...####.", "...####.", "........", "........", "........",
        ],
        &[
            "........", "..#.....", "..#.....", "..#.....", "..#.....", "..#.....", "........", "........",
        ],
        &[
            "........", "........", "..######", "........", "........", "........", "........", "........",
        ],
        &[
            "........", "..####..", "..#..#..", "..#..#..", "..####..", "........", "........", "........",
        ],
        &[
            "........", "........", "...#....", "........", "........", "....#...", "........", "........",
        ],
        &[
            "##......", "###.....", "####....", "#####...", "######..", "#######.", "########", "########",
        ],
        &[
            "........", ".#.#.#..", "........", ".#.#.#..", "........", "..###...", "..#.#...", "..###...",
        ],
        &[
            "..#..#..", "..#..#..", "..#..#..", "..####..", "........", "#......#", "#......#", "########",
        ],
    ];
    let settings = Settings {
        max_search: 16,
        epsilon: 2.5e-5,
    };
    let mut flagged = 0;
    for (k, rows) in patterns.iter().enumerate() {
        let grid = pattern(rows);
        let oracle = Oracle {
            map: &grid,
            max_search: 16,
            eps: 2.5e-5,
        };
        for y in 0..grid.h * 4 {
            for x in 0..grid.w * 4 {
                let (u, v, z) = ((x as f32 + 0.5) / 4.0, (y as f32 + 0.5) / 4.0, 0.5);
                for f in [Function::Smsr, Function::Rsmss] {
                    let (got, work) = visibility::visibility(&grid, u, v, z, f, &settings);
                    flagged += work.flagged as u32;
                    let want = match f {
                        Function::Smsr => oracle.smsr(u, v, z),
                        Function::Rsmss => oracle.rsmss(u, v, z),
                    };
                    assert_eq!(
                        got.to_bits(),
                        want.to_bits(),
                        "pattern {k} {f:?} at ({u}, {v}): {got} vs {want}"
                    );
                    assert!((0.0..=1.0).contains(&got), "pattern {k} {f:?}: {got}");
                }
            }
        }
    }
    assert!(flagged > 500);
}

#[test]
fn smsr_only_darkens_and_unflagged_fragments_keep_the_plain_test() {
    let mut rng = Rng(77);
    let settings = Settings {
        max_search: 16,
        epsilon: 2.5e-5,
    };
    for _ in 0..300 {
        let (grid, plane) = random_map(&mut rng);
        for _ in 0..50 {
            let (u, v) = (rng.range(0.0, grid.w as f32), rng.range(0.0, grid.h as f32));
            let z = plane[0] + plane[1] * u + plane[2] * v;
            let plain = (z <= grid.depth(u.floor() as i64, v.floor() as i64)) as u8 as f32;
            let (smsr, work) = visibility::visibility(&grid, u, v, z, Function::Smsr, &settings);
            // SMSR never lights a fragment the plain test shadows.
            assert!(smsr <= plain, "SMSR {smsr} > plain {plain}");
            let (rsmss, rw) = visibility::visibility(&grid, u, v, z, Function::Rsmss, &settings);
            if !work.flagged {
                assert_eq!(smsr, plain);
            }
            if !rw.flagged {
                assert_eq!(rsmss, plain);
            }
        }
    }
}
