/* Opens a region of byte-packed structs (no padding between members).
 *
 * Generated message headers bracket every struct like this:
 *
 *     #include "ln/packed.h"
 *     typedef struct LN_PACKED { uint8_t a; double b; } example_t;
 *     #include "ln/endpacked.h"
 *
 * Deliberately without include guard: each pair of includes opens and closes
 * one region, so the pair may appear any number of times in a translation
 * unit. GCC and Clang pack through the LN_PACKED attribute; MSVC has no such
 * attribute, so the region itself is packed with #pragma pack instead.
 */
#if defined(_MSC_VER)
#define LN_PACKED
#pragma pack(push, 1)
#else
#define LN_PACKED __attribute__((__packed__))
#endif
