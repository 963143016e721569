/* status.c -- names for vt_status codes (messages in bindings and demos). */
#include "vehtrack/status.h"
#include <stddef.h>

vt_status vt_status_name(int code, const char **name)
{
    if (name == NULL) {
        return VT_E_ARG;
    }
    switch (code) {
    case VT_OK: *name = "ok"; return VT_OK;
    case VT_E_ARG: *name = "bad argument"; return VT_OK;
    case VT_E_SIZE: *name = "bad size"; return VT_OK;
    case VT_E_CAPACITY: *name = "capacity exceeded"; return VT_OK;
    case VT_E_SINGULAR: *name = "singular (division by zero)"; return VT_OK;
    default: *name = "unknown status"; return VT_E_ARG;
    }
}
