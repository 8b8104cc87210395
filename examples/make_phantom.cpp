// placeholder; the foundation helper replaces this file
int main() { return 0; }
