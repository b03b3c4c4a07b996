/* A minimal Cortex-M0+ program whose contents depend on CASE_HEAP / CASE_FLOAT. */
#include <stdlib.h>

volatile int sink;
volatile float fsink = 1.5f;

int main(void);
int main(void) {
#if defined(CASE_HEAP)
    void *p = malloc(16);
    sink = p != NULL;
    free(p);
#elif defined(CASE_FLOAT)
    sink = (int)(fsink * 3.0f);
#else
    sink = 3;
#endif
    return 0;
}
