
#include <math.h>
#include <stdint.h>
#include <string.h>
typedef void (*kernel_t)(double*, const double*, const double*, const double*, const int*,
                         const uint8_t*);
/* out[f, c] = the element matrix (n x n) of form f on cell c, by its FFCx kernel */
void tabulate_cells(int nforms, const uintptr_t* kernels, int ncells, int n, double* out,
                    const double* const* coeffs, const int* ncoeff,
                    const double* const* consts, const double* coords, int ncoord)
{
  const long size = (long)n * n;
  for (int f = 0; f < nforms; ++f)
  {
    kernel_t kernel = (kernel_t)kernels[f];
    double* A = out + (long)f * ncells * size;
    memset(A, 0, sizeof(double) * size * ncells);
    for (int c = 0; c < ncells; ++c)
      kernel(A + c * size, coeffs[f] + (long)c * ncoeff[f], consts[f],
             coords + (long)c * ncoord * 3, 0, 0);
  }
}

/* The blocks' matrices are assembled from the element matrices E (nf forms x cells x n x n,
   row-major) as sum_f weights[b, f] E[f, c], cells taken in chain order (cell order[p] between
   chain vertices p and p + 1), diagonals scaled by `scale`; the ni interior rows irow[p] of a
   cell are eliminated by Cholesky, and the Schur complement on its nv vertex rows vrow[p]
   (lower vertex first) is added into LAPACK's lower band storage (kd = nv - 1, column-major
   (kd + 1) x size, entry (i, j) at (i - j) + j (kd + 1)). NL blocks go through a cell in
   lockstep, one per lane of GCC's vector type (SIMD where the CPU has it): every lane reads
   the same element entry and its own weight; each lane's arithmetic is that of its block
   alone, in the same order (no fused multiply-adds: -ffp-contract=off), so the values do not
   depend on which blocks share a call. A lane whose interior pivot is not positive (or not
   finite) goes on with a unit pivot, its block already marked failed. */
#define NI_MAX 32
#define NV_MAX 32
#define NK_MAX 8
/* LAPACK's banded LU with partial pivoting (the process's own liblapack: PETSc's, scipy's) */
void dgbtrf_(const int* m, const int* n, const int* kl, const int* ku, double* ab,
             const int* ldab, int* ipiv, int* info);

/* ab: n columns of 3 kd + 1 doubles (column-major general band storage, A[i, j] at row
   2 kd + i - j, kd rows of fill-in above), factored in place as dgbtrf; piv 1-based. Returns
   dgbtrf's info (0: factored, > 0: an exactly zero pivot). */
int band_lu(double* ab, int n, int kd, int* piv)
{
  const int ldab = 3 * kd + 1;
  int info = 0;
  dgbtrf_(&n, &n, &kd, &kd, ab, &ldab, piv, &info);
  return info;
}

/* LDL^T without pivoting of a symmetric band matrix (LAPACK's lower band storage, as
   condense_chain's, kd <= NV_MAX), in place; counts[0] / counts[1] = the negative / positive
   pivots. Returns 0, or 1 where the factorisation cannot vouch for the inertia: a zero or
   non-finite diagonal entry or pivot, or growth: a diagonal entry of |L| |D| |L^T| (its
   off-diagonal entries are bounded by the diagonal's geometric means) above `growth` times
   |a_jj|. Within that growth, the factors are those of A + dA with |dA_ij| <= (kd + 1) eps
   growth sqrt(|a_ii a_jj|) (to first order): the inertia of the diagonally scaled matrix up
   to a perturbation of that size (the error analysis of Cholesky, Higham, Accuracy
   and Stability of Numerical Algorithms, ch. 10, applies to LDL^T without pivoting). */
int band_ldlt(double* ab, int n, int kd, double growth, int* counts)
{
  const int kd1 = kd + 1;
  double v[NV_MAX + 1];
  counts[0] = counts[1] = 0;
  if (kd > NV_MAX) return 1;
  for (int j = 0; j < n; ++j)
  {
    const int k0 = j - kd > 0 ? j - kd : 0;
    const double ajj = ab[j * kd1];
    if (!(fabs(ajj) > 0.0) || !isfinite(ajj)) return 1;
    /* v_k = L_jk d_k for k < j; d_j = a_jj - sum L_jk v_k; g = sum L_jk^2 |d_k| + |d_j| */
    double d = ajj, g = 0.0;
    for (int k = k0; k < j; ++k)
    {
      const double ljk = ab[(j - k) + k * kd1];
      const double dk = ab[k * kd1];
      v[k - k0] = ljk * dk;
      d -= ljk * v[k - k0];
      g += ljk * ljk * fabs(dk);
    }
    g += fabs(d);
    if (!(fabs(d) > 0.0) || !isfinite(d) || !(g <= growth * fabs(ajj))) return 1;
    ab[j * kd1] = d;
    counts[d < 0.0 ? 0 : 1] += 1;
    const int iend = j + kd < n - 1 ? j + kd : n - 1;
    for (int i = j + 1; i <= iend; ++i)
    {
      /* L_ij = (a_ij - sum_{k >= i - kd} L_ik v_k) / d_j */
      double t = ab[(i - j) + j * kd1];
      const int ks = i - kd > k0 ? i - kd : k0;
      for (int k = ks; k < j; ++k) t -= ab[(i - k) + k * kd1] * v[k - k0];
      ab[(i - j) + j * kd1] = t / d;
    }
  }
  return 0;
}

/* out[c] = 2 T^T C[c] T for each cell's n x n matrix, T the change of unknowns that maps the
   pairs (s[k], d[k]) to their half sum and half difference (x'_s = (x_s + x_d) / 2,
   x'_d = (x_s - x_d) / 2), the identity elsewhere: columns, then rows. */
void sum_difference(int ncells, int n, int npairs, const int* s, const int* d,
                    const double* C, double* out)
{
  const long nn = (long)n * n;
  for (long i = 0; i < (long)ncells * nn; ++i) out[i] = 2.0 * C[i];
  for (int c = 0; c < ncells; ++c)
  {
    double* A = out + c * nn;
    for (int r = 0; r < n; ++r)
      for (int k = 0; k < npairs; ++k)
      {
        const double a = A[r * n + s[k]], b = A[r * n + d[k]];
        A[r * n + s[k]] = 0.5 * (a + b);
        A[r * n + d[k]] = 0.5 * (a - b);
      }
    for (int k = 0; k < npairs; ++k)
      for (int j = 0; j < n; ++j)
      {
        const double a = A[s[k] * n + j], b = A[d[k] * n + j];
        A[s[k] * n + j] = 0.5 * (a + b);
        A[d[k] * n + j] = 0.5 * (a - b);
      }
  }
}

/* Solves with a matrix condensed by condense_chain (nb = 1, its factors kept) and its vertex
   Schur complement factored by LAPACK's dgbtrf (lu: (2 kd + kd + 1) x size, column-major,
   kl = ku = kd; piv: its 1-based row interchanges): H x = b is L z = b_I per cell, then
   S x_V = b_V - sum Y^T z (dgbtrs' algorithm: the row interchanges and L, then U), then
   L^T x_I = z - Y x_V. idof[p * ni + i]: the global DOF of chain cell p's interior row i;
   vdof[q]: the global DOF of the condensed vertex index q; fixed[q]: q is constrained (its
   coupling to the interior is dropped: the constrained matrix's column is zero). z (cells x
   ni) and bv (size) are work arrays. */
void chain_solve(int ncells, int ni, int nv, const double* keep_l, const double* keep_y,
                 const int* idof, const int* vdof, const char* fixed, int size,
                 const double* lu, const int* piv, const double* b, double* z, double* bv,
                 double* x)
{
  const int half = nv / 2, kd = nv - 1, ldab = 3 * kd + 1;
  double xl[NV_MAX];
  for (int q = 0; q < size; ++q) bv[q] = b[vdof[q]];
  for (int p = 0; p < ncells; ++p)
  {
    const double* l = keep_l + (long)p * ni * ni;
    const double* y = keep_y + (long)p * ni * nv;
    double* zp = z + (long)p * ni;
    for (int i = 0; i < ni; ++i)
    {
      double t = b[idof[p * ni + i]];
      for (int j = 0; j < i; ++j) t -= l[i * ni + j] * zp[j];
      zp[i] = t / l[i * ni + i];
    }
    const long base = (long)p * half;
    for (int j = 0; j < nv; ++j) xl[j] = 0.0;
    for (int i = 0; i < ni; ++i)
      for (int j = 0; j < nv; ++j) xl[j] += y[i * nv + j] * zp[i];
    for (int j = 0; j < nv; ++j)
      if (!fixed[base + j]) bv[base + j] -= xl[j];
  }
  /* L: the interchanges and unit lower factor, column by column (entries at row 2 kd + i - j) */
  for (int j = 0; j < size - 1; ++j)
  {
    const int lm = kd < size - 1 - j ? kd : size - 1 - j;
    const int jp = piv[j] - 1;
    if (jp != j) { double t = bv[jp]; bv[jp] = bv[j]; bv[j] = t; }
    const double* col = lu + (long)j * ldab + 2 * kd;
    for (int i = 1; i <= lm; ++i) bv[j + i] -= col[i] * bv[j];
  }
  /* U: upper with 2 kd superdiagonals, U[i, j] at row 2 kd + i - j of column j */
  for (int j = size - 1; j >= 0; --j)
  {
    const double* col = lu + (long)j * ldab;
    bv[j] /= col[2 * kd];
    const double t = bv[j];
    const int i0 = j - 2 * kd > 0 ? j - 2 * kd : 0;
    for (int i = i0; i < j; ++i) bv[i] -= col[2 * kd + i - j] * t;
  }
  for (int q = 0; q < size; ++q) x[vdof[q]] = bv[q];
  for (int p = 0; p < ncells; ++p)
  {
    const double* l = keep_l + (long)p * ni * ni;
    const double* y = keep_y + (long)p * ni * nv;
    double* zp = z + (long)p * ni;
    const long base = (long)p * half;
    for (int j = 0; j < nv; ++j) xl[j] = fixed[base + j] ? 0.0 : bv[base + j];
    for (int i = 0; i < ni; ++i)
    {
      double t = zp[i];
      for (int j = 0; j < nv; ++j) t -= y[i * nv + j] * xl[j];
      zp[i] = t;
    }
    for (int i = ni - 1; i >= 0; --i)
    {
      double t = zp[i];
      for (int j = i + 1; j < ni; ++j) t -= l[j * ni + i] * zp[j];
      zp[i] = t / l[i * ni + i];
      x[idof[p * ni + i]] = zp[i];
    }
  }
}

/* out = the sum of w[i] at pos[i], added in the order of i: np.bincount(pos, w)'s values, bit
   for bit (the same additions in the same order), without its new array */
void scatter_add(long n, const long* pos, const double* w, long nout, double* out)
{
  for (long j = 0; j < nout; ++j) out[j] = 0.0;
  for (long i = 0; i < n; ++i) out[pos[i]] += w[i];
}
