// Gauss-Legendre quadrature nodes and weights on [0, 1] (host side: used once
// per material to tabulate integrals). Nodes are the roots of the Legendre
// polynomial P_n, found by Newton's method from Tricomi's initial guesses
// cos(π (i + 3/4) / (n + 1/2)); weights 2 / ((1 - x²) P_n'(x)²), both mapped
// from [-1, 1] to [0, 1] (Abramowitz & Stegun 25.4.29; Numerical Recipes §4.6).
#pragma once

#include <cmath>
#include <vector>

namespace luz {

inline void gauss_legendre_01(int n, std::vector<double>& nodes, std::vector<double>& weights) {
  nodes.assign(size_t(n), 0.0);
  weights.assign(size_t(n), 0.0);
  const double pi = 3.14159265358979323846;
  for (int i = 0; i < (n + 1) / 2; ++i) {
    double x = std::cos(pi * (i + 0.75) / (n + 0.5)), dp = 1.0;
    for (int it = 0; it < 100; ++it) {
      double p0 = 1.0, p1 = x;  // P_0, P_1; recurrence (k+1) P_{k+1} = (2k+1) x P_k - k P_{k-1}
      for (int k = 1; k < n; ++k) {
        double p2 = ((2.0 * k + 1.0) * x * p1 - k * p0) / (k + 1.0);
        p0 = p1;
        p1 = p2;
      }
      dp = n * (x * p1 - p0) / (x * x - 1.0);  // P_n'(x)
      double dx = p1 / dp;
      x -= dx;
      if (std::fabs(dx) < 1e-15) break;
    }
    double w = 2.0 / ((1.0 - x * x) * dp * dp);
    // x and -x: mapped to [0, 1], ascending.
    nodes[size_t(i)] = 0.5 * (1.0 - x);
    nodes[size_t(n - 1 - i)] = 0.5 * (1.0 + x);
    weights[size_t(i)] = weights[size_t(n - 1 - i)] = 0.5 * w;
  }
}

}  // namespace luz
