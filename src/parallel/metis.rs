//! METIS (Debian's `libmetis-dev`, 5.1) through a hand-kept FFI of the one call the partition
//! needs: `METIS_PartMeshDual`, which partitions a mesh's tets by their dual graph (tets that
//! share a face are neighbours), minimising the faces cut. With a fixed seed the answer depends
//! only on the mesh: the same parts on every run.
//!
//! **Safety.** The arrays passed have the lengths METIS reads (checked by the indexing that
//! builds them); idx_t is 32-bit and real_t 32-bit in Debian's build (`metis.h`:
//! IDXTYPEWIDTH = REALTYPEWIDTH = 32); METIS keeps no pointer after it returns.

use std::ffi::c_int;

type Idx = i32;

const METIS_OK: c_int = 1;
const METIS_NOPTIONS: usize = 40;
const METIS_OPTION_SEED: usize = 8;
const METIS_OPTION_NUMBERING: usize = 17;

#[link(name = "metis")]
unsafe extern "C" {
    fn METIS_SetDefaultOptions(options: *mut Idx) -> c_int;
    #[allow(clippy::too_many_arguments)]
    fn METIS_PartMeshDual(
        ne: *mut Idx,
        nn: *mut Idx,
        eptr: *mut Idx,
        eind: *mut Idx,
        vwgt: *mut Idx,
        vsize: *mut Idx,
        ncommon: *mut Idx,
        nparts: *mut Idx,
        tpwgts: *mut f32,
        options: *mut Idx,
        objval: *mut Idx,
        epart: *mut Idx,
        npart: *mut Idx,
    ) -> c_int;
}

/// The seed of METIS's randomised matching: fixed, so that parts are reproducible.
const SEED: Idx = 20_260_101;

/// The part of each tet of `tets` (over `vertices` vertices) among `parts`, and the number of
/// faces cut; Err with METIS's return code.
pub fn partition_tets(
    vertices: usize,
    tets: &[[usize; 4]],
    parts: usize,
) -> Result<(Vec<u32>, usize), String> {
    if parts <= 1 || tets.is_empty() {
        return Ok((vec![0; tets.len()], 0));
    }
    let too_big = |what: &str| format!("{what} exceed METIS's 32-bit indices");
    let mut ne = Idx::try_from(tets.len()).map_err(|_| too_big("the tets"))?;
    let mut nn = Idx::try_from(vertices).map_err(|_| too_big("the vertices"))?;
    Idx::try_from(4 * tets.len()).map_err(|_| too_big("the tets' corners"))?;
    let mut eptr: Vec<Idx> = (0..=tets.len()).map(|t| 4 * t as Idx).collect();
    let mut eind: Vec<Idx> = tets.iter().flatten().map(|&v| v as Idx).collect();
    let mut ncommon: Idx = 3;
    let mut nparts = Idx::try_from(parts).map_err(|_| too_big("the ranks"))?;
    let mut options = [0 as Idx; METIS_NOPTIONS];
    let mut objval: Idx = 0;
    let mut epart = vec![0 as Idx; tets.len()];
    let mut npart = vec![0 as Idx; vertices];
    // SAFETY: see the module docs: every array has the length METIS reads or writes (eptr
    // ne + 1, eind 4·ne, epart ne, npart nn, options METIS_NOPTIONS); null weights are allowed.
    let code = unsafe {
        METIS_SetDefaultOptions(options.as_mut_ptr());
        options[METIS_OPTION_SEED] = SEED;
        options[METIS_OPTION_NUMBERING] = 0;
        METIS_PartMeshDual(
            &mut ne,
            &mut nn,
            eptr.as_mut_ptr(),
            eind.as_mut_ptr(),
            std::ptr::null_mut(),
            std::ptr::null_mut(),
            &mut ncommon,
            &mut nparts,
            std::ptr::null_mut(),
            options.as_mut_ptr(),
            &mut objval,
            epart.as_mut_ptr(),
            npart.as_mut_ptr(),
        )
    };
    if code != METIS_OK {
        return Err(format!("METIS_PartMeshDual failed (code {code})"));
    }
    Ok((epart.iter().map(|&p| p as u32).collect(), objval as usize))
}
