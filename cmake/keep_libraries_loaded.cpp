// Sanitizer builds only (CMakeLists.txt links this into every executable when VIM_SANITIZE is on):
// dlclose() that keeps the library loaded. MPI_Finalize unloads OpenMPI's plugins (mca_*.so), and
// LeakSanitizer, which symbolises the stacks of the leaks it finds at exit, then attributes their
// frames to an <unknown module> that no suppression (scripts/lsan.supp) can name. With the plugins
// still loaded, the stacks name them even with the fast unwinder (ASAN_OPTIONS=fast_unwind_on_malloc=1),
// which is several times cheaper per allocation than full unwinding. OpenMPI 4.1 has no parameter
// for this (its mca_base_component_disable_dlclose came later). The definition in the executable
// takes precedence over libc's for every library of the process (exported: -Wl,--export-dynamic-symbol).
extern "C" int dlclose(void*) { return 0; }
