# Sourced by scripts/build.sh and scripts/fuzz.sh (ROOT = the clone). ccache (when installed) keeps
# its objects outside the clone, in ~/.cache/ccache, so a new clone or a clean build folder reuses
# them: base_dir makes the paths it hashes relative to the clone, and hash_dir=false leaves the
# build folder out of the hash (the -g1 sanitizer and fuzz builds would otherwise miss in every new
# folder). The source and build paths are compiled into three small files only (tests/common,
# apps/common, libs/sim). The sloppiness lets it cache the units that use the precompiled LibTorch
# header (CMakeLists.txt, OBM_TORCH_PCH).
export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$ROOT}"
export CCACHE_NOHASHDIR="${CCACHE_NOHASHDIR:-1}"
export CCACHE_SLOPPINESS="${CCACHE_SLOPPINESS:-pch_defines,time_macros,include_file_mtime,include_file_ctime}"
export CCACHE_MAXSIZE="${CCACHE_MAXSIZE:-8G}"
