#include "obm/registration/robust_kernel.hpp"

#include <cmath>

#include "obm/core/errors.hpp"

namespace obm::registration {

double robustWeight(RobustKernel kernel, double r, double c) {
  const double a = std::abs(r);
  switch (kernel) {
    case RobustKernel::None:
      return 1.0;
    case RobustKernel::Huber:
      return a <= c ? 1.0 : c / a;
    case RobustKernel::Cauchy: {
      const double u = r / c;
      return 1.0 / (1.0 + u * u);
    }
    case RobustKernel::GemanMcClure: {
      const double u = r / c;
      const double d = 1.0 + u * u;
      return 1.0 / (d * d);
    }
    case RobustKernel::Tukey: {
      if (a >= c) return 0.0;
      const double u = r / c;
      const double d = 1.0 - u * u;
      return d * d;
    }
  }
  return 1.0;
}

double robustCost(RobustKernel kernel, double r, double c) {
  const double r2 = r * r;
  switch (kernel) {
    case RobustKernel::None:
      return 0.5 * r2;
    case RobustKernel::Huber: {
      const double a = std::abs(r);
      return a <= c ? 0.5 * r2 : c * (a - 0.5 * c);
    }
    case RobustKernel::Cauchy:
      return 0.5 * c * c * std::log1p(r2 / (c * c));
    case RobustKernel::GemanMcClure:
      return 0.5 * r2 / (1.0 + r2 / (c * c));
    case RobustKernel::Tukey: {
      const double c2 = c * c;
      if (r2 >= c2) return c2 / 6.0;
      const double d = 1.0 - r2 / c2;
      return c2 / 6.0 * (1.0 - d * d * d);
    }
  }
  return 0.5 * r2;
}

RobustKernel parseRobustKernel(const std::string& name, const std::string& where) {
  if (name == "none") return RobustKernel::None;
  if (name == "huber") return RobustKernel::Huber;
  if (name == "cauchy") return RobustKernel::Cauchy;
  if (name == "geman_mcclure" || name == "gm") return RobustKernel::GemanMcClure;
  if (name == "tukey") return RobustKernel::Tukey;
  throw ConfigError(where + ": unknown robust kernel '" + name +
                    "' (none, huber, cauchy, geman_mcclure, tukey)");
}

std::string toString(RobustKernel kernel) {
  switch (kernel) {
    case RobustKernel::None:
      return "none";
    case RobustKernel::Huber:
      return "huber";
    case RobustKernel::Cauchy:
      return "cauchy";
    case RobustKernel::GemanMcClure:
      return "geman_mcclure";
    case RobustKernel::Tukey:
      return "tukey";
  }
  return "none";
}

}  // namespace obm::registration
