
void tabulate_cells(int nforms, const uintptr_t* kernels, int ncells, int n, double* out,
                    const double* const* coeffs, const int* ncoeff,
                    const double* const* consts, const double* coords, int ncoord);
int band_ldlt(double* ab, int n, int kd, double growth, int* counts);
int band_lu(double* ab, int n, int kd, int* piv);
void chain_solve(int ncells, int ni, int nv, const double* keep_l, const double* keep_y,
                 const int* idof, const int* vdof, const char* fixed, int size,
                 const double* lu, const int* piv, const double* b, double* z, double* bv,
                 double* x);
void scatter_add(long n, const long* pos, const double* w, long nout, double* out);
void sum_difference(int ncells, int n, int npairs, const int* s, const int* d,
                    const double* C, double* out);
