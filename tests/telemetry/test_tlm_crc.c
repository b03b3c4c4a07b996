/* CRC-16/CCITT-FALSE: the catalogue check value, the nibble table against a
 * bit-at-a-time reference, and incremental use. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "telemetry/tlm_crc.h"

/* Reference: the textbook MSB-first shift register, one bit at a time. */
static uint16_t crc16_bitwise(uint16_t crc, const uint8_t *data, size_t len) {
    for (size_t i = 0; i < len; ++i) {
        uint32_t reg = crc ^ ((uint32_t)data[i] << 8);
        for (int bit = 0; bit < 8; ++bit) {
            reg = (reg & 0x8000u) ? ((reg << 1) ^ 0x1021u) : (reg << 1);
        }
        crc = (uint16_t)(reg & 0xFFFFu);
    }
    return crc;
}

static void test_check_value_of_123456789(void **state) {
    (void)state;
    const uint8_t check[] = "123456789";
    assert_int_equal(tlm_crc16(TLM_CRC_INIT, check, 9), 0x29B1);
    assert_int_equal(TLM_CRC_CHECK, 0x29B1);
}

static void test_empty_input_leaves_register_unchanged(void **state) {
    (void)state;
    assert_int_equal(tlm_crc16(TLM_CRC_INIT, NULL, 0), 0xFFFF);
    assert_int_equal(tlm_crc16(0x1234, NULL, 0), 0x1234);
}

static void test_known_vectors(void **state) {
    (void)state;
    /* Single bytes and a zero run, computed by the bitwise reference definition. */
    const uint8_t zero = 0x00, a = 'A', ff = 0xFF;
    assert_int_equal(tlm_crc16(TLM_CRC_INIT, &zero, 1), crc16_bitwise(0xFFFF, &zero, 1));
    assert_int_equal(tlm_crc16(TLM_CRC_INIT, &a, 1), 0xB915); /* CCITT-FALSE("A") */
    assert_int_equal(tlm_crc16(TLM_CRC_INIT, &ff, 1), 0xFF00);
}

static void test_matches_bitwise_reference_on_pseudorandom_data(void **state) {
    (void)state;
    uint8_t data[1024];
    uint32_t x = 0x12345678u;
    for (size_t i = 0; i < sizeof data; ++i) {
        x = x * 1664525u + 1013904223u; /* Numerical Recipes LCG */
        data[i] = (uint8_t)(x >> 24);
    }
    for (size_t len = 0; len <= sizeof data; len += 7) {
        assert_int_equal(tlm_crc16(TLM_CRC_INIT, data, len), crc16_bitwise(0xFFFF, data, len));
    }
}

static void test_incremental_equals_one_shot(void **state) {
    (void)state;
    const uint8_t msg[] = "The quick brown fox jumps over the lazy dog";
    const size_t len = sizeof msg - 1;
    const uint16_t whole = tlm_crc16(TLM_CRC_INIT, msg, len);
    for (size_t split = 0; split <= len; ++split) {
        uint16_t crc = tlm_crc16(TLM_CRC_INIT, msg, split);
        crc = tlm_crc16(crc, msg + split, len - split);
        assert_int_equal(crc, whole);
    }
}

static void test_detects_every_single_bit_error(void **state) {
    (void)state;
    uint8_t msg[32];
    for (size_t i = 0; i < sizeof msg; ++i) {
        msg[i] = (uint8_t)(i * 37u + 11u);
    }
    const uint16_t good = tlm_crc16(TLM_CRC_INIT, msg, sizeof msg);
    for (size_t bit = 0; bit < sizeof msg * 8; ++bit) {
        msg[bit / 8] ^= (uint8_t)(1u << (bit % 8));
        assert_int_not_equal(tlm_crc16(TLM_CRC_INIT, msg, sizeof msg), good);
        msg[bit / 8] ^= (uint8_t)(1u << (bit % 8));
    }
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_check_value_of_123456789),
        cmocka_unit_test(test_empty_input_leaves_register_unchanged),
        cmocka_unit_test(test_known_vectors),
        cmocka_unit_test(test_matches_bitwise_reference_on_pseudorandom_data),
        cmocka_unit_test(test_incremental_equals_one_shot),
        cmocka_unit_test(test_detects_every_single_bit_error),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
