//! Save and load of a [`Precomputed`] transfer (bytemuck, little-endian native
//! layout; files are not portable to big-endian machines).
//!
//! Layout: magic `b"WLXMESH\0"`, `u32` version, `u32` reserved, `u64` scene hash,
//! then length-prefixed sections (`u64` byte count each): the configuration (JSON),
//! the points per level (`u64` count and `f64` radius per level, then six `f64` per
//! point), `T`, `S` (each `u64` rows, cols, nnz; `u64` row pointers; `u32` columns;
//! nine `f64` per link) and the statistics (JSON). Every length is checked on load;
//! a short file is [`FileProblem::Truncated`], another scene's file
//! [`FileProblem::SceneHash`]. Saving writes a temporary file and renames it, so an
//! existing file is never left half-written.

use std::io::Write;
use std::path::Path;

use glam::DVec3;

use crate::basis::{Basis, BasisPoint};
use crate::config::MeshlessConfig;
use crate::error::{FileProblem, MeshlessError};
use crate::matrix::TransferMatrix;
use crate::relight::{PrecomputeStats, Precomputed};

/// Magic bytes at the start of a transfer file.
pub const MAGIC: &[u8; 8] = b"WLXMESH\0";
/// Format version written and read.
pub const VERSION: u32 = 1;

fn io_err(path: &Path, e: impl std::fmt::Display) -> MeshlessError {
    MeshlessError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

fn section(out: &mut Vec<u8>, bytes: &[u8]) {
    out.extend_from_slice(&(bytes.len() as u64).to_le_bytes());
    out.extend_from_slice(bytes);
}

fn matrix_bytes(m: &TransferMatrix) -> Vec<u8> {
    let mut b = Vec::new();
    for v in [m.rows as u64, m.cols as u64, m.col.len() as u64] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    let ptr: Vec<u64> = m.row_ptr.iter().map(|&p| p as u64).collect();
    b.extend_from_slice(bytemuck::cast_slice(&ptr));
    b.extend_from_slice(bytemuck::cast_slice(&m.col));
    let flat: Vec<f64> = m.val.iter().flatten().copied().collect();
    b.extend_from_slice(bytemuck::cast_slice(&flat));
    b
}

impl Precomputed {
    /// Writes the transfer to `path` (temporary file + rename).
    ///
    /// # Errors
    /// [`MeshlessError::Io`] if writing fails.
    pub fn save(&self, path: &Path) -> Result<(), MeshlessError> {
        let mut out = Vec::new();
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&VERSION.to_le_bytes());
        out.extend_from_slice(&0u32.to_le_bytes());
        out.extend_from_slice(&self.scene_hash.to_le_bytes());
        let cfg = serde_json::to_vec(&self.config).map_err(|e| io_err(path, e))?;
        section(&mut out, &cfg);
        let b = &self.basis;
        let mut pts = Vec::new();
        pts.extend_from_slice(&(b.levels() as u64).to_le_bytes());
        for l in 0..b.levels() {
            pts.extend_from_slice(&(b.level_range(l).len() as u64).to_le_bytes());
            pts.extend_from_slice(&b.radius(l).to_le_bytes());
        }
        let mut xs = Vec::with_capacity(b.len() * 6);
        for i in 0..b.len() {
            xs.extend_from_slice(&b.position(i).to_array());
            xs.extend_from_slice(&b.normal(i).to_array());
        }
        pts.extend_from_slice(bytemuck::cast_slice(&xs));
        section(&mut out, &pts);
        section(&mut out, &matrix_bytes(&self.t));
        section(&mut out, &matrix_bytes(&self.s));
        let stats = serde_json::to_vec(&self.stats).map_err(|e| io_err(path, e))?;
        section(&mut out, &stats);
        let dir = path
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let tmp = dir.join(format!(".{name}.tmp{}", std::process::id()));
        let res = (|| -> std::io::Result<()> {
            let mut f = std::fs::File::create(&tmp)?;
            f.write_all(&out)?;
            f.sync_all()?;
            std::fs::rename(&tmp, path)
        })();
        if let Err(e) = res {
            let _ = std::fs::remove_file(&tmp);
            return Err(io_err(path, e));
        }
        Ok(())
    }

    /// Reads a transfer written by [`Precomputed::save`]; `scene_hash` must match the
    /// file's (pass [`crate::scene_hash`] of the scene it will light).
    ///
    /// # Errors
    /// [`MeshlessError::Io`] if reading fails; [`MeshlessError::File`] for a bad magic,
    /// version, scene hash, truncation or corrupt values.
    pub fn load(path: &Path, scene_hash: u64) -> Result<Self, MeshlessError> {
        let bytes = std::fs::read(path).map_err(|e| io_err(path, e))?;
        parse(&bytes, scene_hash).map_err(|problem| MeshlessError::File {
            path: path.display().to_string(),
            problem,
        })
    }
}

/// A cursor over the file's bytes.
struct Reader<'a> {
    b: &'a [u8],
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], FileProblem> {
        if self.b.len() < n {
            return Err(FileProblem::Truncated);
        }
        let (a, rest) = self.b.split_at(n);
        self.b = rest;
        Ok(a)
    }
    fn u32(&mut self) -> Result<u32, FileProblem> {
        let mut a = [0u8; 4];
        a.copy_from_slice(self.take(4)?);
        Ok(u32::from_le_bytes(a))
    }
    fn u64(&mut self) -> Result<u64, FileProblem> {
        let mut a = [0u8; 8];
        a.copy_from_slice(self.take(8)?);
        Ok(u64::from_le_bytes(a))
    }
    fn f64(&mut self) -> Result<f64, FileProblem> {
        Ok(f64::from_bits(self.u64()?))
    }
    fn len(&mut self, size: usize, count: u64) -> Result<usize, FileProblem> {
        usize::try_from(count)
            .ok()
            .and_then(|c| c.checked_mul(size))
            .filter(|&n| n <= self.b.len())
            .ok_or(FileProblem::Truncated)
    }
    fn section(&mut self) -> Result<Reader<'a>, FileProblem> {
        let n = self.u64()?;
        let n = self.len(1, n)?;
        Ok(Reader { b: self.take(n)? })
    }
}

fn corrupt(what: impl Into<String>) -> FileProblem {
    FileProblem::Corrupt(what.into())
}

fn read_matrix(mut r: Reader<'_>) -> Result<TransferMatrix, FileProblem> {
    let rows = r.u64()? as usize;
    let cols = r.u64()? as usize;
    let nnz = r.u64()?;
    let nptr = r.len(8, rows as u64 + 1)?;
    let row_ptr: Vec<usize> = bytemuck::pod_collect_to_vec::<u8, u64>(r.take(nptr)?)
        .into_iter()
        .map(|p| p as usize)
        .collect();
    let ncol = r.len(4, nnz)?;
    let col: Vec<u32> = bytemuck::pod_collect_to_vec(r.take(ncol)?);
    let nval = r.len(72, nnz)?;
    let flat: Vec<f64> = bytemuck::pod_collect_to_vec(r.take(nval)?);
    let nnz = nnz as usize;
    if row_ptr.first() != Some(&0)
        || row_ptr.last() != Some(&nnz)
        || row_ptr.windows(2).any(|w| w[0] > w[1])
    {
        return Err(corrupt("row pointers"));
    }
    if col.iter().any(|&c| c as usize >= cols) {
        return Err(corrupt("column index out of range"));
    }
    if flat.iter().any(|v| !v.is_finite()) {
        return Err(corrupt("non-finite link"));
    }
    let val = flat
        .chunks_exact(9)
        .map(|c| std::array::from_fn(|k| c[k]))
        .collect();
    Ok(TransferMatrix {
        rows,
        cols,
        row_ptr,
        col,
        val,
    })
}

fn parse(bytes: &[u8], scene_hash: u64) -> Result<Precomputed, FileProblem> {
    let mut r = Reader { b: bytes };
    if r.take(8).map_err(|_| FileProblem::Magic)? != MAGIC {
        return Err(FileProblem::Magic);
    }
    let version = r.u32()?;
    if version != VERSION {
        return Err(FileProblem::Version {
            found: version,
            expected: VERSION,
        });
    }
    let _ = r.u32()?;
    let found = r.u64()?;
    if found != scene_hash {
        return Err(FileProblem::SceneHash {
            found,
            expected: scene_hash,
        });
    }
    let cfg = r.section()?;
    let config: MeshlessConfig =
        serde_json::from_slice(cfg.b).map_err(|e| corrupt(format!("configuration: {e}")))?;
    config
        .validate()
        .map_err(|e| corrupt(format!("configuration: {e}")))?;
    let mut pts = r.section()?;
    let levels = pts.u64()? as usize;
    if levels == 0 || levels > crate::MAX_LEVELS {
        return Err(corrupt(format!("{levels} levels")));
    }
    let mut counts = Vec::with_capacity(levels);
    let mut radii = Vec::with_capacity(levels);
    for _ in 0..levels {
        counts.push(pts.u64()? as usize);
        radii.push(pts.f64()?);
    }
    let total: u64 = counts.iter().map(|&c| c as u64).sum();
    let n = pts.len(48, total)?;
    let xs: Vec<f64> = bytemuck::pod_collect_to_vec(pts.take(n)?);
    let mut lv = Vec::with_capacity(levels);
    let mut k = 0;
    for &c in &counts {
        let mut v = Vec::with_capacity(c);
        for _ in 0..c {
            let p = &xs[k * 6..k * 6 + 6];
            v.push(BasisPoint {
                x: DVec3::new(p[0], p[1], p[2]),
                n: DVec3::new(p[3], p[4], p[5]),
            });
            k += 1;
        }
        lv.push(v);
    }
    let basis = Basis::from_levels(&lv, &radii, config.sender_levels)
        .map_err(|e| corrupt(format!("points: {e}")))?;
    if basis.dropped() > 0 {
        return Err(corrupt("invalid point"));
    }
    let t = read_matrix(r.section()?)?;
    let s = read_matrix(r.section()?)?;
    let senders = basis.level_start(config.sender_levels.min(basis.levels()));
    for m in [&t, &s] {
        if m.rows != basis.len() || m.cols != senders {
            return Err(corrupt("matrix shape does not match the basis"));
        }
    }
    let st = r.section()?;
    let stats: PrecomputeStats =
        serde_json::from_slice(st.b).map_err(|e| corrupt(format!("statistics: {e}")))?;
    Ok(Precomputed {
        config,
        basis,
        t,
        s,
        stats,
        scene_hash,
    })
}
