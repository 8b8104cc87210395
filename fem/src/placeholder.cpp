// placeholder; FEM helper replaces this file
