/* The kernel's share of the lockstep loop: a pty round trip with no Python on either end.
 * The parent writes a HIL_SENSOR-sized frame (77 bytes) on the master; a child reading the
 * raw slave answers with a HIL_ACTUATOR_CONTROLS-sized one (93 bytes). Prints µs per round trip. */
#define _GNU_SOURCE
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/wait.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

enum { SENSOR_BYTES = 77, ACTUATOR_BYTES = 93 };

static void make_raw(int fd) {
    struct termios t;
    tcgetattr(fd, &t);
    cfmakeraw(&t);
    tcsetattr(fd, TCSANOW, &t);
}

static int read_exactly(int fd, char *buf, int want) {
    for (int got = 0; got < want;) {
        int n = (int)read(fd, buf + got, (size_t)(want - got));
        if (n <= 0) return -1;
        got += n;
    }
    return 0;
}

int main(int argc, char **argv) {
    int rounds = argc > 1 ? atoi(argv[1]) : 20000;
    int master = posix_openpt(O_RDWR | O_NOCTTY);
    if (master < 0 || grantpt(master) || unlockpt(master)) return 1;
    int slave = open(ptsname(master), O_RDWR | O_NOCTTY);
    if (slave < 0) return 1;
    make_raw(master);
    make_raw(slave);
    char frame[ACTUATOR_BYTES] = {0};
    if (fork() == 0) {
        for (int i = 0; i < rounds; i++) {
            if (read_exactly(slave, frame, SENSOR_BYTES)) _exit(1);
            if (write(slave, frame, ACTUATOR_BYTES) != ACTUATOR_BYTES) _exit(1);
        }
        _exit(0);
    }
    struct timespec start, end;
    clock_gettime(CLOCK_MONOTONIC, &start);
    for (int i = 0; i < rounds; i++) {
        if (write(master, frame, SENSOR_BYTES) != SENSOR_BYTES) return 1;
        if (read_exactly(master, frame, ACTUATOR_BYTES)) return 1;
    }
    clock_gettime(CLOCK_MONOTONIC, &end);
    wait(NULL);
    double us = ((double)(end.tv_sec - start.tv_sec) * 1e9 + (double)(end.tv_nsec - start.tv_nsec)) / 1e3;
    printf("%.1f\n", us / rounds);
    return 0;
}
