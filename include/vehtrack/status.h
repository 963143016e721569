/* vehtrack/status.h -- the status every public function returns.
 *
 * 0 is success; failures are negative so `if (s < 0)` catches them all.
 * Results always leave through pointers, never through the return value, so an
 * error can never be mistaken for a result. */
#ifndef VEHTRACK_STATUS_H
#define VEHTRACK_STATUS_H

typedef enum {
    VT_OK = 0,
    VT_E_ARG = -1,      /* NULL pointer or an argument outside its domain */
    VT_E_SIZE = -2,     /* a size is zero/negative, over the compile-time maximum,
                           or two sizes that must agree do not */
    VT_E_CAPACITY = -3, /* a compile-time capacity would be exceeded */
    VT_E_SINGULAR = -4  /* a division by zero: singular matrix, flat patch */
} vt_status;

/* A short English name for a status code, for messages: *name is set to a
 * static string. An unknown code gives VT_E_ARG and the name "unknown status". */
vt_status vt_status_name(int code, const char **name);

#endif /* VEHTRACK_STATUS_H */
