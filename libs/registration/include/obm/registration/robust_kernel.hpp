#pragma once
/// \file robust_kernel.hpp
/// M-estimator kernels ρ(r) for the ICP cost Σ ρ(r_i), solved by iteratively re-weighted least
/// squares: each residual gets the weight w(r) = ρ'(r)/r (Zhang, "Parameter estimation
/// techniques: a tutorial with application to conic fitting", 1997, Table 1). All kernels satisfy
/// ρ(r) ≈ r²/2 and w(r) ≈ 1 for |r| ≪ c, so the scale c is the residual size [m] beyond which
/// a correspondence starts to be down-weighted.
#include <string>

namespace obm::registration {

/// Robust kernel of the ICP cost.
enum class RobustKernel {
  None,          ///< ρ = r²/2 (plain least squares)
  Huber,         ///< quadratic up to c, linear beyond: w = min(1, c/|r|)
  Cauchy,        ///< ρ = c²/2·log(1 + r²/c²): w = 1/(1 + r²/c²)
  GemanMcClure,  ///< ρ = (r²/2)/(1 + r²/c²): w = 1/(1 + r²/c²)²
  Tukey,         ///< biweight, w = (1 − r²/c²)² inside c, 0 beyond (hard rejection)
};

/// IRLS weight w(r) = ρ'(r)/r ∈ [0, 1] of a residual `r` for kernel scale `c` > 0.
double robustWeight(RobustKernel kernel, double r, double c);

/// Kernel value ρ(r) (the cost the Levenberg–Marquardt step acceptance compares).
double robustCost(RobustKernel kernel, double r, double c);

/// Parses "none", "huber", "cauchy", "geman_mcclure" (or "gm"), "tukey"; throws ConfigError
/// prefixed with `where` otherwise.
RobustKernel parseRobustKernel(const std::string& name, const std::string& where = "kernel");

/// The name parseRobustKernel accepts.
std::string toString(RobustKernel kernel);

}  // namespace obm::registration
