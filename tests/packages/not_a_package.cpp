// A shared library named like a package (pkg_none.dca.so) without dca's entry point: the loader refuses it.
extern "C" int pkg_none_answer() { return 42; }
