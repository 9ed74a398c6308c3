/* Closes the region opened by "ln/packed.h" (see there). No include guard. */
#if defined(_MSC_VER)
#pragma pack(pop)
#endif
#undef LN_PACKED
