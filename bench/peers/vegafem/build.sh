#!/usr/bin/env bash
# Build vega_beam: compile the few VegaFEM sources an implicit Newton solve of a Neo-Hookean tet
# mesh needs (no GUI, no OpenGL, no TBB, no MKL: VegaFEM then selects its Jacobi-preconditioned
# CG) into a static library, and link our driver against it. Needs only g++ (C++14).
#
#   bench/peers/vegafem/build.sh VEGA_SRC [BUILD_DIR]
#
# VEGA_SRC: a checkout of https://github.com/dyollb/VegaFEM (tested at commit
# bcbd9868de4bde4da2047d0595bce7d7f39ff2d7); BUILD_DIR defaults to VEGA_SRC/build-tetsim-bench.
# Optimisation as CMake's Release (-O3 -DNDEBUG), no -march=native (tetsim's release build has
# none either).
set -euo pipefail

if [ $# -lt 1 ]; then
  echo "usage: $0 VEGA_SRC [BUILD_DIR]" >&2
  exit 2
fi
vega=$(cd "$1" && pwd)
lib="$vega/libraries"
[ -f "$lib/integratorSparse/implicitBackwardEulerSparse.cpp" ] || {
  echo "$0: $vega does not look like a VegaFEM checkout (no libraries/integratorSparse)" >&2
  exit 1
}
build=${2:-"$vega/build-tetsim-bench"}
mkdir -p "$build/obj"
here=$(cd "$(dirname "$0")" && pwd)
cxx=${CXX:-g++}
flags=(-std=c++14 -O3 -DNDEBUG -ffunction-sections -fdata-sections)

# VegaFEM's CMake configures vega-config.h; with every option off it defines nothing.
printf '#pragma once\n' >"$build/vega-config.h"
includes=(-I"$build")
for d in "$lib"/*/; do includes+=(-I"$d"); done

sources=(
  isotropicHyperelasticFEM/isotropicHyperelasticFEM.cpp
  isotropicHyperelasticFEM/isotropicMaterial.cpp
  isotropicHyperelasticFEM/isotropicMaterialWithCompressionResistance.cpp
  isotropicHyperelasticFEM/neoHookeanIsotropicMaterial.cpp
  elasticForceModel/isotropicHyperelasticFEMForceModel.cpp
  forceModel/forceModel.cpp
  integratorSparse/implicitBackwardEulerSparse.cpp
  integratorSparse/implicitNewmarkSparse.cpp
  integratorSparse/integratorBaseSparse.cpp
  integrator/integratorBase.cpp
  volumetricMesh/tetMesh.cpp
  volumetricMesh/volumetricMesh.cpp
  volumetricMesh/generateMassMatrix.cpp
  volumetricMesh/volumetricMeshParser.cpp
  volumetricMesh/volumetricMeshENuMaterial.cpp
  volumetricMesh/volumetricMeshMooneyRivlinMaterial.cpp
  volumetricMesh/volumetricMeshOrthotropicMaterial.cpp
  sparseMatrix/sparseMatrix.cpp
  sparseSolver/CGSolver.cpp
  sparseSolver/linearSolver.cpp
  constrainedDOFs/constrainedDOFs.cpp
  mesh/boundingBox.cpp
  mesh/geometryQuery.cpp
  minivector/mat3d.cpp
  minivector/eig3.cpp
  minivector/vec3d.cpp
)
objects=()
for s in "${sources[@]}"; do
  o="$build/obj/$(basename "$s" .cpp).o"
  objects+=("$o")
  if [ ! -f "$o" ] || [ "$lib/$s" -nt "$o" ]; then
    echo "compiling $s"
    "$cxx" "${flags[@]}" "${includes[@]}" -c "$lib/$s" -o "$o"
  fi
done
rm -f "$build/libvega-bench.a"
ar rcs "$build/libvega-bench.a" "${objects[@]}"

# --gc-sections drops the bounding box's OpenGL drawing (never called); --wrap lets the driver
# count the CG iterations of VegaFEM's Jacobi-preconditioned CG (see vega_beam.cpp).
"$cxx" "${flags[@]}" "${includes[@]}" "$here/vega_beam.cpp" -o "$build/vega_beam" \
  "$build/libvega-bench.a" -Wl,--gc-sections \
  -Wl,--wrap=_ZN8CGSolver41SolveLinearSystemWithJacobiPreconditionerEPdPKddii
echo "built $build/vega_beam"
