# All third-party packages are found here, once. Everything comes from Debian packages
# (scripts/setup.sh installs them).
find_package(Eigen3 3.3 REQUIRED NO_MODULE)
find_package(Threads REQUIRED)
find_package(yaml-cpp REQUIRED)
find_package(nlohmann_json 3 REQUIRED)
find_package(PNG REQUIRED)
find_package(JPEG REQUIRED)  # colour frames of RGB-D layouts (libjpeg-turbo)

# MRPT 2.x (rawlog, observations)
find_package(mrpt-obs REQUIRED)
find_package(mrpt-maps REQUIRED)  # CObservationPointCloud lives in mrpt-maps
find_package(mrpt-poses REQUIRED)  # CPose3DPDFGaussian (libs/mrpt_bridge)
find_package(mrpt-opengl REQUIRED)  # COpenGLScene (.3Dscene output)
find_package(mrpt-slam QUIET)      # CICP: the peer of the bridge's tests

# HDF5 (ModelNet40 files), C API
find_package(HDF5 REQUIRED COMPONENTS C)

find_package(Ceres REQUIRED)
find_package(octomap REQUIRED)
find_package(embree 3 REQUIRED)
find_package(nanoflann QUIET)

if(OBM_WITH_TORCH)
  find_package(Torch REQUIRED)
endif()
if(OBM_WITH_OPEN3D)
  find_package(Open3D QUIET)
endif()

# tcmalloc (Debian libtcmalloc-minimal4 ships only the versioned .so): applications only, and not
# under the sanitizers, which bring their own allocator.
set(OBM_TCMALLOC_LIBRARY "")
if(OBM_WITH_TCMALLOC AND NOT OBM_SANITIZE)
  find_library(OBM_TCMALLOC_FOUND NAMES tcmalloc_minimal libtcmalloc_minimal.so.4)
  if(OBM_TCMALLOC_FOUND)
    set(OBM_TCMALLOC_LIBRARY ${OBM_TCMALLOC_FOUND})
    message(STATUS "obmslam: applications linked with ${OBM_TCMALLOC_FOUND}")
  else()
    message(STATUS "obmslam: tcmalloc_minimal not found (libtcmalloc-minimal4); glibc malloc")
  endif()
endif()
