// placeholder; the foundation helper replaces this file
