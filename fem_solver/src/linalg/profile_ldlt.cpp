#include "profile_ldlt.hpp"

#include <algorithm>
#include <cmath>

namespace cosim::fem {
namespace {

/// A's graph as its column pattern (both triangles stored: column v lists v's neighbours).
struct Graph {
  const int* outer;
  const int* inner;
  int degree(int v) const { return outer[v + 1] - outer[v]; }
};

/// Breadth-first level structure from root, confined to root's component:
/// the vertices in visiting order, and where the last level starts.
struct Levels {
  std::vector<int> order;
  std::size_t lastLevel = 0;
  int depth = 0;
};

Levels levelsFrom(const Graph& g, int root, std::vector<int>& stamp, int mark) {
  Levels l;
  l.order.push_back(root);
  stamp[static_cast<std::size_t>(root)] = mark;
  std::size_t begin = 0;
  while (begin < l.order.size()) {
    const std::size_t end = l.order.size();
    l.lastLevel = begin;
    for (std::size_t q = begin; q < end; ++q) {
      const int v = l.order[q];
      for (int k = g.outer[v]; k < g.outer[v + 1]; ++k) {
        const int w = g.inner[k];
        if (stamp[static_cast<std::size_t>(w)] != mark) {
          stamp[static_cast<std::size_t>(w)] = mark;
          l.order.push_back(w);
        }
      }
    }
    begin = end;
    if (begin < l.order.size()) ++l.depth;
  }
  return l;
}

/// A pseudo-peripheral vertex of start's component (George & Liu 1979): move
/// to a lowest-degree vertex of the last level while the depth grows.
int pseudoPeripheral(const Graph& g, int start, std::vector<int>& stamp, int& mark) {
  int root = start;
  Levels l = levelsFrom(g, root, stamp, ++mark);
  for (int tries = 0; tries < 8; ++tries) {
    int best = l.order[l.lastLevel];
    for (std::size_t q = l.lastLevel; q < l.order.size(); ++q)
      if (g.degree(l.order[q]) < g.degree(best)) best = l.order[q];
    Levels next = levelsFrom(g, best, stamp, ++mark);
    if (next.depth <= l.depth) break;
    root = best;
    l = std::move(next);
  }
  return root;
}

}  // namespace

void ProfileLdlt::analyse(const SparseSystem::Matrix& A) {
  const int n = static_cast<int>(A.rows());
  const Graph g{A.outerIndexPtr(), A.innerIndexPtr()};
  std::vector<int> stamp(static_cast<std::size_t>(n), 0), order;
  order.reserve(static_cast<std::size_t>(n));
  std::vector<char> placed(static_cast<std::size_t>(n), 0);
  int mark = 0;
  for (int s = 0; s < n; ++s) {  // Cuthill-McKee, component by component
    if (placed[static_cast<std::size_t>(s)]) continue;
    const int root = pseudoPeripheral(g, s, stamp, mark);
    std::size_t head = order.size();
    order.push_back(root);
    placed[static_cast<std::size_t>(root)] = 1;
    while (head < order.size()) {
      const int v = order[head++];
      const std::size_t begin = order.size();
      for (int k = g.outer[v]; k < g.outer[v + 1]; ++k) {
        const int w = g.inner[k];
        if (!placed[static_cast<std::size_t>(w)]) {
          placed[static_cast<std::size_t>(w)] = 1;
          order.push_back(w);
        }
      }
      std::sort(order.begin() + static_cast<std::ptrdiff_t>(begin), order.end(), [&g](int a, int b) {
        return g.degree(a) != g.degree(b) ? g.degree(a) < g.degree(b) : a < b;
      });
    }
  }
  std::reverse(order.begin(), order.end());  // reversing shrinks the envelope (George 1971)
  oldOf_ = std::move(order);
  newOf_.assign(static_cast<std::size_t>(n), 0);
  for (int i = 0; i < n; ++i) newOf_[static_cast<std::size_t>(oldOf_[static_cast<std::size_t>(i)])] = i;
  first_.assign(static_cast<std::size_t>(n), 0);
  offset_.assign(static_cast<std::size_t>(n) + 1, 0);
  for (int i = 0; i < n; ++i) {
    int f = i;
    const int o = oldOf_[static_cast<std::size_t>(i)];
    for (int k = g.outer[o]; k < g.outer[o + 1]; ++k) f = std::min(f, newOf_[static_cast<std::size_t>(g.inner[k])]);
    first_[static_cast<std::size_t>(i)] = f;
    offset_[static_cast<std::size_t>(i) + 1] = offset_[static_cast<std::size_t>(i)] + static_cast<std::size_t>(i - f);
  }
  work_.assign(static_cast<std::size_t>(n), 0.0);
}

int ProfileLdlt::factorize(const SparseSystem::Matrix& A, double relPivot) {
  const int n = static_cast<int>(A.rows());
  const int* outer = A.outerIndexPtr();
  const int* inner = A.innerIndexPtr();
  const double* value = A.valuePtr();
  lower_.assign(envelopeSize(), 0.0);
  pivots_.assign(static_cast<std::size_t>(n), 0.0);
  // Row i of P A P^T is column oldOf_[i] of A.
  for (int i = 0; i < n; ++i) {
    const int o = oldOf_[static_cast<std::size_t>(i)];
    double* row = lower_.data() + offset_[static_cast<std::size_t>(i)] - first_[static_cast<std::size_t>(i)];
    for (int k = outer[o]; k < outer[o + 1]; ++k) {
      const int j = newOf_[static_cast<std::size_t>(inner[k])];
      if (j < i) row[j] = value[k];
      else if (j == i) pivots_[static_cast<std::size_t>(i)] = value[k];
    }
  }
  // Row by row (the bordering method): L_ij D_j = A_ij - sum_k L_ik D_k L_jk.
  std::vector<double> scaled(static_cast<std::size_t>(n), 0.0);  // L_ik D_k of the current row
  const double* D = pivots_.data();
  for (int i = 0; i < n; ++i) {
    const int fi = first_[static_cast<std::size_t>(i)];
    double* li = lower_.data() + offset_[static_cast<std::size_t>(i)] - fi;
    double d = pivots_[static_cast<std::size_t>(i)];
    for (int j = fi; j < i; ++j) {
      const int fj = first_[static_cast<std::size_t>(j)];
      const double* lj = lower_.data() + offset_[static_cast<std::size_t>(j)] - fj;
      double s = li[j];
      for (int k = std::max(fi, fj); k < j; ++k) s -= scaled[static_cast<std::size_t>(k)] * lj[k];
      scaled[static_cast<std::size_t>(j)] = s;
      li[j] = s / D[j];
      d -= s * li[j];
    }
    pivots_[static_cast<std::size_t>(i)] = d;
  }
  double largest = 0.0;
  for (double p : pivots_) {
    if (!std::isfinite(p)) return oldOf_[static_cast<std::size_t>(&p - pivots_.data())];
    largest = std::max(largest, std::abs(p));
  }
  for (int i = 0; i < n; ++i)
    if (!(std::abs(pivots_[static_cast<std::size_t>(i)]) > relPivot * largest)) return oldOf_[static_cast<std::size_t>(i)];
  return -1;
}

void ProfileLdlt::solve(const double* b, double* x) const {
  const int n = static_cast<int>(pivots_.size());
  double* y = work_.data();
  for (int i = 0; i < n; ++i) y[i] = b[oldOf_[static_cast<std::size_t>(i)]];
  for (int i = 0; i < n; ++i) {  // L z = P b
    const int f = first_[static_cast<std::size_t>(i)];
    const double* li = lower_.data() + offset_[static_cast<std::size_t>(i)] - f;
    double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
    int k = f;
    for (; k + 3 < i; k += 4) {
      s0 += li[k] * y[k];
      s1 += li[k + 1] * y[k + 1];
      s2 += li[k + 2] * y[k + 2];
      s3 += li[k + 3] * y[k + 3];
    }
    for (; k < i; ++k) s0 += li[k] * y[k];
    y[i] -= (s0 + s1) + (s2 + s3);
  }
  for (int i = 0; i < n; ++i) y[i] /= pivots_[static_cast<std::size_t>(i)];
  for (int i = n - 1; i >= 0; --i) {  // L^T w = D^-1 z
    const int f = first_[static_cast<std::size_t>(i)];
    const double* li = lower_.data() + offset_[static_cast<std::size_t>(i)] - f;
    const double yi = y[i];
    for (int k = f; k < i; ++k) y[k] -= li[k] * yi;
  }
  for (int i = 0; i < n; ++i) x[oldOf_[static_cast<std::size_t>(i)]] = y[i];
}

}  // namespace cosim::fem
